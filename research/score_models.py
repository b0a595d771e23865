"""Several checkpoints, and ensembles of them, on one labelled dataset: accuracy per assembly.

    python -m research.score_models DATASET LABEL=MODEL.pt [LABEL=A.pt+B.pt+...] ... [--json OUT]

Each ``LABEL=PATHS`` is one checkpoint or, with ``+``, an ensemble whose P(high) is the mean of its
members'. Every model sees the images of its own view (``RowStore.view``: the close-up is rendered
again from ``DATASET/_assemblies``) and the geometric descriptors it was trained with
(``RowStore.with_descriptors``). Prints per label the mean accuracy over assemblies, the pooled
accuracy and ECE, and each assembly's accuracy; then each assembly's noise ceiling. For one model,
``rap-farm score`` gives the same figures with per-class columns.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("models", nargs="+", help="LABEL=PATH or LABEL=PATH+PATH+...")
    ap.add_argument("--json", type=Path, default=None, help="write every figure here")
    a = ap.parse_args()
    specs = []
    for spec in a.models:
        label, sep, paths = spec.partition("=")
        if not sep or not label or not all(Path(x).is_file() for x in paths.split("+")):
            sys.exit(f"{spec}: expected LABEL=PATH[+PATH...] of existing checkpoints")
        specs.append((label, paths.split("+")))

    from rap.model.data.rows import RowStore
    from rap.model.evaluation.cross_validation import group_metrics
    from rap.model.inference.torch_engine import TorchPredictor

    store = RowStore(a.dataset)
    images, probs = {}, {}

    def prob_high(path: str) -> np.ndarray:
        if path not in probs:
            p = TorchPredictor.load(path)
            if p.view not in images:
                images[p.view] = store.view(p.view).images
            im = images[p.view]
            d = store.with_descriptors(p.descriptors).descriptors
            probs[path] = np.concatenate([p.prob_high(im[i:i + 512],
                                                      None if d is None else d[i:i + 512])
                                          for i in range(0, len(im), 512)])
        return probs[path]

    keys = ("accuracy", "low_accuracy", "high_accuracy", "ece", "ceiling", "rows")
    out = {}
    for label, paths in specs:
        p = np.mean([prob_high(x) for x in paths], axis=0)
        rows = group_metrics(store.assembly, store.scores, store.trials, p, 0.95)
        per = {r["assembly"]: r for r in rows[:-1]}
        pooled = rows[-1]
        names = sorted(per)
        mean = float(np.mean([per[n]["accuracy"] for n in names]))
        out[label] = {"models": paths, "mean": mean,
                      "pooled": {k: pooled[k] for k in keys},
                      "per": {n: {k: per[n][k] for k in keys} for n in names}}
        print(f"{label:26s} mean {100 * mean:.1f} pooled {100 * pooled['accuracy']:.1f} ECE "
              f"{100 * pooled['ece']:.1f} | "
              + " ".join(f"{n}:{100 * per[n]['accuracy']:.1f}" for n in names), flush=True)
    first = next(iter(out.values()))["per"]
    print("noise ceiling: " + " ".join(f"{n}:{100 * c['ceiling']:.1f}" for n, c in first.items()))
    if a.json:
        a.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
