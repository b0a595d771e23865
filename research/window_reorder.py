"""Windows of greedy's chain re-ordered exactly: does local re-ordering pay beyond 30 parts?

    python -m research.window_reorder [--assemblies wall:44,grid:49,convex:30] [--window 4]

Simulator-only greedy plans 30-100-part assemblies as a chain (each step splits one part off the
rest). This splits the chain into windows of ``--window`` consecutive steps and, in each, finds the
best order of removing the window's parts from the window's first subassembly (a DP over the
subsets of the window's parts, every candidate operation simulated: the most any re-ordering of
the window can give), then reports the product of the windows' gains (the plan's R would be
multiplied by it) and the extra simulations it took. Assemblies from ``benchmarks/plan_scale.py``
(seed 0), planning seed 11, 100 trials, in this process.

It is an upper bound on what a window search that simulates less could gain; measured (the notes
in research/README.md) it is too small for its cost to replace or join the beam.
"""

from __future__ import annotations

import argparse
import math
import time

from benchmarks.plan_scale import build
from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams


def chain_of(steps) -> list[tuple[frozenset, frozenset, float]]:
    """Greedy's steps in disassembly order as (subassembly, the smaller side, score)."""
    out = []
    for s in reversed(steps):
        m, f = frozenset(s.moving), frozenset(s.fixed)
        out.append((m | f, m if len(m) <= len(f) else f, s.score))
    return out


def best_order(problem, scorer, start: frozenset, units: list[frozenset]) -> float:
    """The best product of removing ``units`` (single parts) from ``start`` in any order, each
    step a candidate of its subassembly with a unit as one side; 0 when none is possible."""
    memo: dict[frozenset, float] = {}

    def value(removed: frozenset) -> float:
        if len(removed) == len(units):
            return 1.0
        if removed in memo:
            return memo[removed]
        here = start - frozenset().union(*(units[i] for i in removed))
        ops = [(i, op) for op in problem.candidates(here) for i in range(len(units))
               if i not in removed and units[i] in (op.moving, op.fixed)]
        scores = scorer.scores(problem, [op for _, op in ops]) if ops else []
        memo[removed] = max((r * value(removed | {i}) for (i, _), r in zip(ops, scores)),
                            default=0.0)
        return memo[removed]

    return value(frozenset())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assemblies", default="wall:44,grid:49,convex:30")
    ap.add_argument("--window", type=int, default=4)
    a = ap.parse_args(argv)
    print("| assembly | greedy R | greedy s | greedy sims | window gain | extra sims | window s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for spec in a.assemblies.split(","):
        kind, n = spec.split(":")
        problem = PlanningProblem(build(kind, int(n)), SimParams(), 11)
        scorer = Scorer(LocalSimulator(), None, ScoreCache())
        t = time.perf_counter()
        greedy = SimPlanner().solve(problem, scorer)
        greedy_s, greedy_sims = time.perf_counter() - t, scorer.stats.sim_run
        chain = chain_of(greedy.steps)
        t, gain, i = time.perf_counter(), 1.0, 0
        while i < len(chain):
            start, units, here, j = chain[i][0], [], chain[i][0], i
            while (j < len(chain) and len(units) < a.window and chain[j][0] == here
                   and len(chain[j][1]) == 1):
                units.append(chain[j][1])
                here, j = here - chain[j][1], j + 1
            if not units:  # a split that is not one part off the rest: left as greedy made it
                i += 1
                continue
            old = math.prod(chain[x][2] for x in range(i, j))
            gain *= best_order(problem, scorer, start, units) / old if old > 0 else 1.0
            i = j
        print(f"| {spec} | {greedy.robustness:.3g} | {greedy_s:.1f} | {greedy_sims} | "
              f"{gain:.3f} | {scorer.stats.sim_run - greedy_sims} | "
              f"{time.perf_counter() - t:.1f} |", flush=True)


if __name__ == "__main__":
    main()
