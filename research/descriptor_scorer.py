"""Fit the cascade's descriptor network (``rap/data/default_model.scorer.npz``) on the corpus.

    python -m research.descriptor_scorer [--out rap/data/default_model.scorer.npz] [--kind gbt|mlp]
        [--band 0.5,0.5] [--seed 0] [--epochs 24]

Rows: every row of ``datasets/corpus`` (the shipped CNN's training data), its twelve exact
descriptors (``rap.model.data.views.descriptor_columns``, cached under ``$RAP_CACHE_DIR``: about
a minute the first time). The ``validation`` assemblies of ``datasets/splits.json`` (27 generated
assemblies) are held out of training; the calibration temperature (``rap.model.network.heads
.fit_temperature``, P(high) against the 0.95 class) is fitted on their rows.

Trees (``--kind gbt``, shipped): LightGBM, the cross-entropy objective on the success rates
(weights: trials / 100), 400 rounds of 63 leaves at learning rate 0.1, at least 50 rows a leaf,
seeded and deterministic, 2 threads: one logit of the per-trial success probability, as the
network's. Network (``--kind mlp``): the descriptors and the logs of five of them (``LOG_COLUMNS``; ``rap.model.inference
.descriptor_model.features``), standardised, 17-128-128-64-1 with ReLU, one logit of the per-trial success
probability trained on the success counts (binomial log likelihood, the CNN's ``binomial``
head), Adam at 2e-3 with a cosine schedule, batches of 1024, ``--epochs``; seeded (torch and
the batch order), so the same command on the same rows gives the same file on the same machine.
``--band`` is stored for ``CascadeScorer`` (the P(high) range sent to the CNN; chosen on the
unseen set by ``python -m research.scorer_evaluation --bands ...``). The file records the
shipped checkpoint's SHA-256 (``load_default`` uses it only beside that checkpoint), the
training rows' fingerprint, the command and the figures on the held-out rows. Beside it,
``NAME.bounds.json``: split-conformal score bounds (``rap.model.calibration.fit``, 6 bins) of
the network's expected scores, fitted on the held-out rows (``CascadeScorer.bounds``).

Cost: a few minutes on 2 cores (the descriptors once, then 1-10 s an epoch, by load).
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CHECKPOINT = ROOT / "rap" / "data" / "default_model.pt"
HIDDEN = (128, 128, 64)
#: range width, margin, sliding and facing contact, depth: log(1e-4 + x) added as inputs
LOG_COLUMNS = (0, 1, 7, 8, 9)


def corpus_rows(root: Path = ROOT / "datasets" / "corpus"):
    """(RowStore, descriptors float32 [N, 12]) of a dataset."""
    from rap.model.data.descriptors import DESCRIPTORS
    from rap.model.data.rows import RowStore
    from rap.model.data.views import descriptor_columns

    store = RowStore(root)
    return store, descriptor_columns(store, DESCRIPTORS)


def train(x: np.ndarray, successes: np.ndarray, trials: np.ndarray, epochs: int, seed: int):
    """(mean, scale, layers) of a network fitted to the rows (module doc)."""
    import torch

    torch.manual_seed(seed)
    mean = x.mean(axis=0)
    scale = x.std(axis=0) + 1e-6
    xt = torch.tensor((x - mean) / scale, dtype=torch.float32)
    st = torch.tensor(successes, dtype=torch.float32)
    nt = torch.tensor(trials, dtype=torch.float32)
    sizes = [x.shape[1], *HIDDEN, 1]
    mods = []
    for i, (a, b) in enumerate(zip(sizes, sizes[1:])):
        mods.append(torch.nn.Linear(a, b))
        if i < len(sizes) - 2:
            mods.append(torch.nn.ReLU())
    net = torch.nn.Sequential(*mods)
    opt = torch.optim.Adam(net.parameters(), 2e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    gen = torch.Generator().manual_seed(seed)
    logsig = torch.nn.functional.logsigmoid
    for ep in range(epochs):
        t = time.perf_counter()
        perm = torch.randperm(len(xt), generator=gen)
        total = 0.0
        for i in range(0, len(perm), 1024):
            j = perm[i:i + 1024]
            z = net(xt[j])[:, 0]
            loss = -(st[j] * logsig(z) + (nt[j] - st[j]) * logsig(-z)).sum() / nt[j].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(j)
        sched.step()
        print(f"epoch {ep + 1}/{epochs}: loss {total / len(xt):.4f} "
              f"({time.perf_counter() - t:.1f} s)", flush=True)
    layers = [(m.weight.detach().numpy().T.copy(), m.bias.detach().numpy().copy())
              for m in net if isinstance(m, torch.nn.Linear)]
    return mean.astype(np.float32), scale.astype(np.float32), layers


GBT_PARAMS = {"objective": "cross_entropy", "num_leaves": 63, "learning_rate": 0.1,
              "min_data_in_leaf": 50, "verbose": -1, "seed": 0, "deterministic": True,
              "num_threads": 2}
GBT_ROUNDS = 400


def train_gbt(x: np.ndarray, successes: np.ndarray, trials: np.ndarray, seed: int) -> str:
    """A LightGBM model's text fitted to the rows (module doc)."""
    import lightgbm

    data = lightgbm.Dataset(x, label=successes / trials, weight=trials / 100.0)
    booster = lightgbm.train({**GBT_PARAMS, "seed": seed}, data, GBT_ROUNDS)
    return booster.model_to_string()


def main(argv=None) -> None:
    from rap.model.calibration import DEFAULT_BINS, fit, save
    from rap.model.evaluation.metrics import classification_metrics
    from rap.model.inference.cascade import bounds_path
    from rap.model.inference.cascade import checkpoint_sha256
    from rap.model.inference.descriptor_model import DescriptorModel, features
    from rap.model.network.heads import fit_temperature

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "rap" / "data" / "default_model.scorer.npz"))
    ap.add_argument("--kind", choices=("gbt", "mlp"), default="gbt")
    ap.add_argument("--epochs", type=int, default=24, help="MLP only")
    ap.add_argument("--band", default="0.5,0.5")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    store, x = corpus_rows()
    held = set(json.loads((ROOT / "datasets" / "splits.json").read_text())["validation"]["assemblies"])
    va = np.isin(store.assembly, sorted(held))
    tr = np.flatnonzero(~va)
    print(f"{len(tr)} training rows, {int(va.sum())} held-out rows ({len(held)} assemblies); "
          f"descriptors in {time.perf_counter() - t0:.0f} s", flush=True)
    threshold, trials = 0.95, int(np.median(store.trials))
    if a.kind == "gbt":
        text = train_gbt(x[tr].astype(np.float64), store.successes[tr], store.trials[tr], a.seed)
        model = DescriptorModel(None, None, [], {"threshold": threshold, "trials": trials,
                                                 "gbt": {**GBT_PARAMS, "rounds": GBT_ROUNDS}},
                                booster=text)
    else:
        f = features(x, LOG_COLUMNS).astype(np.float64)
        mean, scale, layers = train(f[tr], store.successes[tr], store.trials[tr], a.epochs,
                                    a.seed)
        model = DescriptorModel(mean, scale, layers, {"threshold": threshold, "trials": trials,
                                                      "kind": "mlp",
                                                      "log_columns": list(LOG_COLUMNS),
                                                      "hidden": list(HIDDEN)})
    labels = store.scores[va] >= threshold
    temperature = fit_temperature(model.logits(x[va])[:, None], "binomial", labels, threshold,
                                  trials)
    model.temperature = temperature
    prob, expected = model.prob_high_and_expected(x[va])
    m = classification_metrics(labels, prob)
    lo, hi = (float(v) for v in a.band.split(","))
    model.meta.update(
        temperature=temperature, band=[lo, hi],
        descriptors=list(__import__("rap.model.data.descriptors", fromlist=["D"]).DESCRIPTORS),
        checkpoint="default_model.pt",
        checkpoint_sha256=checkpoint_sha256(CHECKPOINT),
        provenance={
            "command": "python -m research.descriptor_scorer " + " ".join(sys.argv[1:] if argv is None else argv),
            "dataset": "datasets/corpus", "rows": int(len(tr)),
            "rows_fingerprint": store.fingerprint(tr),
            "held_out": sorted(held), "held_out_rows": int(va.sum()),
            "held_out_accuracy": round(float(m["accuracy"]), 4),
            "held_out_ece": round(float(m["ece"]), 4),
            "held_out_mae": round(float(np.abs(expected - store.scores[va]).mean()), 4),
            "epochs": a.epochs if a.kind == "mlp" else None, "seed": a.seed,
            "date": datetime.date.today().isoformat()})
    model.meta["format"] = "rap-farm/descriptor-model"
    model.save(a.out)
    bounds = fit(expected, store.scores[va], bins=DEFAULT_BINS, provenance={
        "model": Path(a.out).name, "set": "validation",
        "calibration": f"the descriptor network's expected scores on the corpus rows of the "
                       f"{len(held)} validation assemblies (datasets/splits.json), held out of "
                       f"its training", "assemblies": sorted(held),
        "simulator": "SimParams() defaults, root seed 20190527, 100 trials an operation",
        "command": model.meta["provenance"]["command"], "date": datetime.date.today().isoformat()})
    save(bounds, bounds_path(a.out))
    print(f"bounds: {bounds.counts} rows a bin, margins at 0.9/0.99: "
          f"{np.round(bounds.margins(0.9), 3).tolist()} / {np.round(bounds.margins(0.99), 3).tolist()}")
    print(f"temperature {temperature:.3f}; held-out accuracy {m['accuracy']:.4f}, ECE "
          f"{m['ece']:.4f}; wrote {a.out} ({Path(a.out).stat().st_size / 1024:.0f} KiB) in "
          f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
