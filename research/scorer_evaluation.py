"""The default scorer against the shipped CNN on the unseen set: accuracy, ECE, bounds' coverage.

    python scripts/make_unseen.py label          # datasets/unseen, once (5,460 labelled rows)
    python -m research.scorer_evaluation [--dataset datasets/unseen] [--bands 0.5:0.5,0.2:0.8]
        [--bounds rap/data/score_bounds.json]

For every labelled row of the dataset (none of them in any model's training data) it scores:

* ``cnn``: the shipped checkpoint alone (``rap/data/default_model.pt``, numpy engine, on the
  stored image pair and the row's exact descriptors): the reference;
* ``descriptors``: the descriptor network alone (``rap/data/default_model.scorer.npz``);
* ``cascade lo:hi``: the descriptor network, and the CNN's numbers for the rows whose
  descriptor P(high) lies strictly inside (lo, hi) (``CascadeScorer``'s rule), for each band
  of ``--bands`` (default: the shipped band and a few others).

Per scorer: class accuracy (P(high) >= 0.5 against score >= 0.95), expected calibration error
(``rap.model.evaluation.metrics``, 10 bins), the mean absolute error of the expected score, the
coverage of the split-conformal upper bounds (fraction of rows with simulated score <= upper(p))
at levels 0.9, 0.95 and 0.99, with the CNN's bounds (``--bounds``, default the shipped
``rap/data/score_bounds.json``) and with the scorer's own (``CascadeScorer.bounds``: the
descriptor model's ``.bounds.json``; the CNN's own are the shipped ones), and the share of rows
the CNN scored. The noise ceiling of the
labels is printed once. Cost: the CNN's forward pass over the rows (about 10 s), the rest
milliseconds.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LEVELS = (0.9, 0.95, 0.99)


def evaluate(labels, scores, prob, expected, bounds, own) -> dict:
    from rap.model.evaluation.metrics import classification_metrics

    m = classification_metrics(labels, prob)
    out = {"accuracy": 100 * m["accuracy"], "ece": 100 * m["ece"],
           "mae": float(np.abs(expected - scores).mean())}
    for level in LEVELS:
        out[f"cov{level}"] = 100 * float(np.mean(scores <= bounds.upper(expected, level) + 1e-12))
        out[f"own{level}"] = 100 * float(np.mean(scores <= own.upper(expected, level) + 1e-12))
    return out


def main(argv=None) -> None:
    from rap.model.calibration import load as load_bounds
    from rap.model.data.descriptors import DESCRIPTORS, columns
    from rap.model.data.rows import RowStore
    from rap.model.data.views import descriptor_columns
    from rap.model.evaluation.metrics import noise_ceiling
    from rap.model.inference.cascade import bounds_path, companion
    from rap.model.inference.descriptor_model import DescriptorModel
    from rap.model.inference.numpy_engine import load_numpy_predictor

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=str(ROOT / "datasets" / "unseen"))
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    ap.add_argument("--scorer", default=None, help="descriptor model [default: beside --model]")
    ap.add_argument("--bands", default=None, help="lo:hi,... [default: shipped and a few]")
    ap.add_argument("--bounds", default=None)
    a = ap.parse_args(argv)
    store = RowStore(a.dataset)
    d = descriptor_columns(store, DESCRIPTORS)
    cnn = load_numpy_predictor(a.model)
    model = DescriptorModel.load(a.scorer or companion(a.model))
    bounds = load_bounds(a.bounds)
    own_path = bounds_path(a.scorer or companion(a.model))
    own = load_bounds(own_path) if own_path.is_file() else bounds
    labels = store.scores >= cnn.threshold
    cd = d[:, columns(cnn.descriptors)] if cnn.descriptors else None
    c_prob, c_exp = cnn.prob_high_and_expected(store.images, cd)
    m_prob, m_exp = model.prob_high_and_expected(d)
    shipped = tuple(model.meta.get("band", (0.5, 0.5)))
    bands = ([tuple(float(v) for v in b.split(":")) for b in a.bands.split(",")] if a.bands
             else sorted({shipped, (0.5, 0.5), (0.4, 0.6), (0.3, 0.7), (0.2, 0.8)}))
    print(f"{a.dataset}: {len(store)} rows of {len(set(store.assembly))} assemblies; noise "
          f"ceiling {100 * noise_ceiling(store.successes, store.trials, cnn.threshold):.1f}; "
          f"bounds {bounds.provenance.get('set', a.bounds)}; shipped band {shipped}")
    head = ("| scorer | accuracy | ECE | MAE | coverage, CNN's bounds 0.9 / 0.95 / 0.99 | "
            "coverage, own bounds | CNN share |\n|---|---:|---:|---:|---:|---:|---:|")
    print(head)
    rows = [("cnn (shipped model)", c_prob, c_exp, 1.0, bounds)]
    for lo, hi in bands:
        unsure = (m_prob > lo) & (m_prob < hi)
        prob, exp = np.where(unsure, c_prob, m_prob), np.where(unsure, c_exp, m_exp)
        name = "descriptors alone" if lo >= hi else f"cascade {lo:g}:{hi:g}"
        if (lo, hi) == shipped:
            name += " (default)"
        rows.append((name, prob, exp, float(unsure.mean()), own))
    for name, prob, exp, share, b in rows:
        r = evaluate(labels, store.scores, prob, exp, bounds, b)
        print(f"| {name} | {r['accuracy']:.1f} | {r['ece']:.1f} | {r['mae']:.4f} | "
              f"{r['cov0.9']:.1f} / {r['cov0.95']:.1f} / {r['cov0.99']:.1f} | "
              f"{r['own0.9']:.1f} / {r['own0.95']:.1f} / {r['own0.99']:.1f} | {100 * share:.1f}% |")


if __name__ == "__main__":
    main()
