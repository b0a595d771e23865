"""The CNN's two inference engines under search: numpy (``rap.model.inference.numpy_engine``) against torch.

``rap-farm plan`` in a fresh process uses the numpy engine (no 2.5 s torch import); the planning
service and ``rap-farm experiment`` load torch once. This plans each assembly with ``search``
(no simulations: the model's cost only) on both engines, interleaved, and prints the best of
``--repeats`` times per assembly and the ratio of the totals (one run, so noise hits both alike).

    python -m research.benchmarks.cnn_engines [--repeats 2] [NAME ...]   # default: five unseen assemblies
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

DEFAULT = ["hub-s101", "convex-s102", "basketweave", "pegs-s103", "wall-s101"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=DEFAULT)
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    ap.add_argument("--dataset", default=str(ROOT / "datasets" / "unseen"))
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()

    from rap.io import load_assembly
    from rap.plan.scoring.cache import ScoreCache
    from rap.experiment.run import dataset_params
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.scorer import Scorer
    from rap.plan.search.planner import SearchPlanner
    from research.benchmarks.search import NoSimulator

    params, seed = dataset_params(args.dataset)
    engines = {"numpy": OperationPredictor.load(args.model, engine="cnn"),
               "torch": OperationPredictor.load(args.model, engine="torch")}
    assert getattr(engines["numpy"].predictor, "engine", None) == "numpy", "not a fastcnn model"
    totals = dict.fromkeys(engines, 0.0)
    print(f"{'assembly':16s} " + " ".join(f"{e:>7s}" for e in engines) + "   (s, search only)")
    for name in args.names:
        found = [p for d in ("assemblies", "assemblies/unseen", "datasets/corpus/_assemblies")
                 if (p := ROOT / d / f"{name}.json").exists()]
        asm = load_assembly(found[0])
        best = dict.fromkeys(engines, float("inf"))
        plans = {}
        for _ in range(args.repeats):
            for e, cnn in engines.items():
                problem = PlanningProblem(asm, params, seed, "online")
                t = time.perf_counter()
                steps = SearchPlanner(simulations=0, upper=0.0)._search(problem, Scorer(NoSimulator(), cnn, ScoreCache()), {})
                best[e] = min(best[e], time.perf_counter() - t)
                plans[e] = [problem.key(s.operation) for s in steps]
        same = "" if plans["numpy"] == plans["torch"] else "  (plans differ)"
        for e in engines:
            totals[e] += best[e]
        print(f"{name:16s} " + " ".join(f"{best[e]:7.2f}" for e in engines) + same)
    print(f"{'total':16s} " + " ".join(f"{totals[e]:7.2f}" for e in engines)
          + f"   numpy / torch: {totals['numpy'] / totals['torch']:.2f}")


if __name__ == "__main__":
    main()
