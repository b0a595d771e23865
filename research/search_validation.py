"""Choose search's ``--trust`` on held-out assemblies without timing anything.

For each (assembly, hold-out model) pair: every operation of the assembly's AND/OR graph gets the
model's expected score and the simulator's score (the corpus's label where the corpus has that
operation, else a fresh simulation with the same seed: the same number). ``SearchPlanner`` then
plans against these tables (a stand-in simulator that looks scores up), for each trust value, and
the plan's robustness is compared with the optimum's (the DP over the simulator's scores).

    python -m research.search_validation --set validation [--trust 0.93,0.95,0.96,0.97,0.98]
    python -m research.search_validation --set test --trust none --optimism 0,0.2,0.4,1
    python -m research.search_validation --set unseen --model OTHER.pt --trust none --optimism 0,0.1

The sets are ``datasets/splits.json``'s (``research.validation_tables``): ``validation``: 3 seeds
of each of the 9 generated families that have a leave-one-family-out model, none of them an
experiment (test) assembly; ``test``: the 14 assemblies of `rap-farm experiment` in
docs/RESULTS.md; ``fresh``: one fresh seed of each of the ten families (``fresh_assemblies``), a
validation set for the shipped model; ``unseen``: the 12 assemblies of `scripts/make_unseen.py`
with an optimum in docs/RESULTS.md (fan-s100 has 11,253 operations), with the shipped model
(labels from datasets/unseen). The tables are cached in ``--cache`` (default
reports/search-validation/); building them simulates a few thousand operations (about 15 minutes
on 2 cores).
"""

from __future__ import annotations

import argparse
import pickle
import statistics
from pathlib import Path

from research.validation_tables import (ROOT, assemblies_of, evaluate, prediction_metrics,
                                        predictions, tables)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("validation", "test", "unseen", "fresh"), default="validation")
    ap.add_argument("--trust", default="0.93,0.95,0.96,0.97,0.98,none")
    ap.add_argument("--simulations", type=int, default=1000, help="budget per plan")
    ap.add_argument("--optimism", default="0", help="comma-separated optimism values to try")
    ap.add_argument("--mirror", action="store_true",
                    help="predictions averaged over each pair and its mirror image")
    ap.add_argument("--model", type=Path,
                    help="predictions of this checkpoint instead (--set unseen: one no model "
                         "here was trained on); the same simulator scores")
    ap.add_argument("--metrics", action="store_true",
                    help="also the predictions' agreement with the simulator on the whole graphs")
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    a = ap.parse_args()
    if a.model is not None and a.set not in ("unseen", "fresh"):
        ap.error("--model needs --set unseen or fresh (the other sets' models are hold-out models)")
    if a.model is not None and a.mirror:
        ap.error("--model and --mirror: one at a time")
    names = assemblies_of(a.set)
    a.cache.mkdir(parents=True, exist_ok=True)
    path = a.cache / f"{a.set}.pkl"
    tabs = pickle.loads(path.read_bytes()) if path.exists() else {}
    missing = [n for n in names if n not in tabs]
    if missing:
        import pyarrow.dataset as ds

        labels = ROOT / "datasets" / {"unseen": "unseen", "fresh": "fresh"}.get(a.set, "corpus")
        dataset = (ds.dataset(str(labels), format="parquet", exclude_invalid_files=True)
                   if labels.is_dir() else None)  # None: every operation simulated here
        print(f"building score tables for {len(missing)} assemblies ...", flush=True)
        for n in missing:
            tabs[n] = tables(n, dataset)
            path.write_bytes(pickle.dumps(tabs))  # resumable: one assembly at a time
    if a.mirror:  # the same simulator scores, mirror-averaged predictions
        mpath = a.cache / f"{a.set}-mirror.pkl"
        mirror = pickle.loads(mpath.read_bytes()) if mpath.exists() else {}
        for n in names:
            if n not in mirror:
                mirror[n] = predictions(n, mirror=True)
                mpath.write_bytes(pickle.dumps(mirror))
        tabs = {n: {"pred": mirror[n], "truth": tabs[n]["truth"]} for n in names}
    if a.model is not None:  # the same simulator scores, another checkpoint's predictions
        import hashlib

        digest = hashlib.sha256(a.model.read_bytes()).hexdigest()[:12]
        ppath = a.cache / f"{a.set}-model-{digest}.pkl"
        other = pickle.loads(ppath.read_bytes()) if ppath.exists() else {}
        for n in names:
            if n not in other:
                other[n] = predictions(n, model=a.model)
                ppath.write_bytes(pickle.dumps(other))
        tabs = {n: {"pred": other[n], "truth": tabs[n]["truth"]} for n in names}
    print(f"{a.set}: {len(names)} assemblies, search with up to {a.simulations} simulations"
          + (", mirror-averaged predictions" if a.mirror else "")
          + (f", predictions of {a.model}" if a.model else ""))
    if a.metrics:
        ms = [prediction_metrics(n, tabs[n]) for n in names]
        print("predictions on the whole graphs (mean over assemblies): "
              + ", ".join(f"{k} {statistics.mean(m[k] for m in ms):.3f}" for k in ms[0]))
    print(f"{'trust':>6} {'optimism':>8} {'R/R opt':>8} {'worst':>6} {'sims':>6}")
    for t in a.trust.split(","):
        trust = None if t == "none" else float(t)
        for u in a.optimism.split(","):
            res = [evaluate(n, tabs[n], trust, a.simulations, float(u)) for n in names]
            ratios = [r for r, _ in res]
            print(f"{t:>6} {u:>8} {statistics.mean(ratios):8.3f} {min(ratios):6.3f} "
                  f"{statistics.mean(s for _, s in res):6.1f}", flush=True)


if __name__ == "__main__":
    main()
