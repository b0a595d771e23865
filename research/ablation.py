"""The scorer's ablation: one row per change, on the same folds and seeds, at a fixed budget.

    python -m research.ablation [--dataset datasets/corpus] [--out reports/ablation]
                               [--max-rows 20000] [--epochs 3] [--seed 0] [--variants a,b,...]
                               [--device cpu|cuda] [--batch-size 64]

Folds: each reference assembly held out (the paper's Table I) and each generated family held out,
every fold trained on a seeded sample of ``--max-rows`` rows of everything else (the same sample
for every variant: the sample depends on the fold and the seed only). Variants are cumulative:
``paper`` is the paper's CNN and loss, each next row adds one change to the previous one. A fold's
result is stored as soon as it is done (``OUT/VARIANT.json``), so an interrupted run resumes where
it stopped. Prints, and writes to ``OUT/table.md``: per variant, the mean accuracy over the
assembly folds and its worst fold, the mean over the family folds, the pooled ECE of each, and the
mean noise ceiling of the test rows.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

VARIANTS = [  # (name, overrides of the 'paper' recipe), cumulative
    ("paper", {}),
    ("+ mirror augmentation", {"augment": "hflip"}),
    ("+ batch norm", {"norm": "batch"}),
    ("+ cosine schedule", {"schedule": "cosine"}),
    ("+ binomial head (success counts)", {"head": "binomial"}),
    ("+ calibration temperature", {"calibrate": True}),
    ("+ close-up of the mating region", {"view": "pair+crop"}),
]


def folds(store):
    fams = sorted(set(store.family.tolist()))
    ref = sorted(set(store.assembly[store.family == "reference"].tolist()))
    return [("assembly", a) for a in ref] + [("family", f) for f in fams
                                             if f not in ("reference", "custom")]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=str(ROOT / "datasets" / "corpus"))
    ap.add_argument("--out", default=str(ROOT / "reports" / "ablation"))
    ap.add_argument("--max-rows", type=int, default=20000)
    ap.add_argument("--epochs", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu", help="cpu, cuda or auto")
    ap.add_argument("--batch-size", type=int, default=64)
    ap.add_argument("--variants", default=None, help="comma-separated indices (default: all)")
    args = ap.parse_args(argv)

    import numpy as np

    from rap.model.data.rows import RowStore
    from rap.model.evaluation.metrics import expected_calibration_error, pool_reliability
    from rap.model.training.recipes import recipe
    from rap.model.training.train import train

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    store = RowStore(args.dataset, order="dataset")  # the row samples of the rows run before
    print(f"{len(store)} rows loaded in {time.perf_counter() - t0:.0f} s", flush=True)
    plan = folds(store)
    chosen = (range(len(VARIANTS)) if args.variants is None
              else [int(i) for i in args.variants.split(",")])
    acc: dict = {}
    for idx in range(len(VARIANTS)):
        acc = {**acc, **VARIANTS[idx][1]}
        if idx not in chosen:
            continue
        name = VARIANTS[idx][0]
        path = out / f"{idx}.json"
        done = json.loads(path.read_text()) if path.exists() else {"variant": name, "folds": {}}
        model_config, config = recipe("paper", epochs=args.epochs, seed=args.seed,
                                      max_rows=args.max_rows, num_threads=args.threads,
                                      device=args.device, batch_size=args.batch_size, **acc)
        for kind, test in plan:
            key = f"{kind}:{test}"
            if key in done["folds"]:
                continue
            t = time.perf_counter()
            res = train(args.dataset, holdout=test if kind == "assembly" else None,
                        holdout_family=test if kind == "family" else None,
                        model_config=model_config, config=config, store=store)
            m = res.metrics["holdout"]
            done["folds"][key] = {"accuracy": m["accuracy"], "low": m["low_accuracy"],
                                  "high": m["high_accuracy"], "ece": m["ece"],
                                  "ceiling": m["ceiling"], "rows": m["rows"],
                                  "reliability": m["reliability"],
                                  "temperature": (res.calibration or {}).get("temperature"),
                                  "seconds": time.perf_counter() - t}
            path.write_text(json.dumps(done, indent=1))
            print(f"[{name}] {key}: accuracy {100 * m['accuracy']:.1f}% (ceiling "
                  f"{100 * m['ceiling']:.1f}%), {time.perf_counter() - t:.0f} s", flush=True)
    lines = ["| variant | assembly folds: mean acc | worst | ECE | family folds: mean acc | "
             "worst | ECE | ceiling (mean) |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for idx, (name, _) in enumerate(VARIANTS):
        path = out / f"{idx}.json"
        if not path.exists():
            continue
        f = json.loads(path.read_text())["folds"]
        cells = []
        for kind in ("assembly", "family"):
            rows = [v for k, v in f.items() if k.startswith(kind + ":")]
            if not rows:
                cells += ["–", "–", "–"]
                continue
            accs = [r["accuracy"] for r in rows]
            ece = expected_calibration_error(pool_reliability([r["reliability"] for r in rows]))
            cells += [f"{100 * np.mean(accs):.1f}", f"{100 * min(accs):.1f}", f"{100 * ece:.1f}"]
        ceil = [r["ceiling"] for r in f.values() if not math.isnan(r["ceiling"])]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {100 * np.mean(ceil):.1f} |")
    table = "\n".join(lines) + "\n"
    (out / "table.md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
