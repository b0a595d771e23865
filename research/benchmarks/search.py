"""Search's exact mode: scoring lazily (branch and bound) against scoring the whole graph first.

For each assembly, ``SearchPlanner`` without simulations plans with the same scorer, alternately
lazily (``rap.plan.dp``: a subassembly's candidates are scored only when it can still matter, one
batch per subassembly) and with the whole graph scored in one batch first
(``research.variants.eager``), ``--repeats`` times each, interleaved; the plans must be identical.
Prints per assembly the operations scored and the median planning times, and the ratio of the
totals (one run, so machine noise hits both alike). ``--engine``: ``auto``, the default scorer
(the shipped search scores the whole graph first with it: ``Scorer.batch_first``), or ``cnn``, the
CNN alone (the shipped search is lazy with it).

    python -m research.benchmarks.search [--engine auto|cnn] [--model rap/data/default_model.pt]
        [--repeats 3] [NAME ...]

Assemblies are looked up in assemblies/, assemblies/unseen/ and datasets/corpus/_assemblies/.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

DEFAULT = ["grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "triangles",
           "c-shapes-s20", "convex-s26", "fan-s12", "funnels-s2", "hub-s32", "knobs-s27",
           "packing-s25", "pegs-s5", "polyomino-s33", "wall-s4"]


class Lazy:
    """A scorer backend as given, but never asking for the whole graph first."""

    batch_first = False

    def __init__(self, backend):
        self.backend = backend

    def __getattr__(self, name):
        return getattr(self.backend, name)


class NoSimulator:
    """A simulator backend that must not be called (search without simulations)."""

    def simulate_many(self, problem, ops):
        raise AssertionError("no simulation expected")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=DEFAULT)
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--engine", choices=("auto", "cnn"), default="auto")
    a = ap.parse_args()

    from rap.io import load_assembly
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.scorer import Scorer
    from rap.plan.search.planner import SearchPlanner
    from research.variants.eager import EagerSearchPlanner
    from rap.sim.params import SimParams

    cnn = OperationPredictor.load(a.model, engine=a.engine)
    dirs = [ROOT / "assemblies", ROOT / "assemblies" / "unseen",
            ROOT / "datasets" / "corpus" / "_assemblies"]
    totals = {True: 0.0, False: 0.0}
    print(f"{'assembly':16s} {'ops':>5s} {'scored':>6s} {'lazy s':>7s} {'all s':>7s} {'ratio':>6s}")
    for name in a.names:
        path = next(d / f"{name}.json" for d in dirs if (d / f"{name}.json").is_file())
        asm = load_assembly(path)
        times = {True: [], False: []}
        plans, st = {}, {}
        warm = PlanningProblem(asm, SimParams(), 1)
        cnn.expected_score(warm, list(warm.candidates(warm.whole))[:2])
        for _ in range(a.repeats):
            for lazy in (True, False):
                problem = PlanningProblem(asm, SimParams(), 1)
                st = {}
                t = time.perf_counter()
                planner = (SearchPlanner if lazy else EagerSearchPlanner)(simulations=0, upper=0.0)
                backend = Lazy(cnn) if lazy else cnn
                steps = planner._search(problem, Scorer(NoSimulator(), backend, ScoreCache()), st)
                times[lazy].append(time.perf_counter() - t)
                plans[lazy] = [(s.moving, s.fixed, s.direction) for s in steps]
                if lazy:
                    scored = st["predicted_operations"]
        if plans[True] != plans[False]:
            sys.exit(f"{name}: the lazy and the full search chose different plans")
        med = {k: statistics.median(v) for k, v in times.items()}
        for k in totals:
            totals[k] += med[k]
        print(f"{name:16s} {st['operations']:5d} {scored:6d} "
              f"{med[True]:7.3f} {med[False]:7.3f} {med[False] / med[True]:6.2f}", flush=True)
    print(f"total: lazy {totals[True]:.2f} s, whole graph first {totals[False]:.2f} s: "
          f"{totals[False] / totals[True]:.2f}x")


if __name__ == "__main__":
    main()
