"""What a perfect scorer would still cost: bounds on issue 11's and issue 13's time targets.

Replays the planners on ``research/search_validation.py``'s score tables (every operation of an
assembly's AND/OR graph with the model's expected score and the simulator's score) with the
*simulator's scores standing in for the model's predictions*: a scorer that is never wrong. Three
counts follow, none of them timed:

1. **Search against greedy** (issue 13: search at most twice greedy RAP's planning time). The
   operations that the exact search (``SearchPlanner``'s branch and bound) renders and scores,
   with the shipped model's predictions and with perfect ones, against the candidates a greedy
   planner scores along its one path (the least CNN work of greedy RAP: each decision's
   candidates, once). Both planners pay the same per operation scored, so when RAP needs no
   simulation the ratio of these counts is the ratio of their planning times.
2. **Cheaper searches with a perfect scorer**: the beam (``SearchPlanner`` beyond its exact budget,
   widths ``--widths``): robustness over the optimum's against operations scored.
3. **Fallbacks a perfect classifier cannot avoid** (issue 11: RAP at least 20 times faster than
   simulator-only greedy). On simulator-only greedy's own path, the decisions where no candidate
   truly scores 0.95 or more: a classifier that is never wrong predicts none of them high, so the
   paper's rule falls back to the simulator there, with every candidate. Their candidates against
   all of simulator-only's bound the speed-up that rule can reach by simulations alone.

    python -m research.search_validation --set unseen      # builds the tables (once)
    python -m research.planning_bounds --set unseen [--per-assembly]

No simulation, no CNN: seconds. Cost: each graph is enumerated once (candidates memoised).
"""

from __future__ import annotations

import argparse
import math
import pickle
import statistics
import sys
from pathlib import Path

from research.validation_tables import ROOT, LookupCnn, LookupSimulator, problem_of

HIGH = 0.95  # the class threshold of the paper and the corpus


def optimum(problem, graph: dict, truth: dict) -> float:
    """The optimum's robustness: the DP over ``truth`` (key -> simulated score) on ``graph``."""
    from rap.plan.dp import dp_choice

    best, _ = dp_choice(graph, {s: [truth[problem.key(op)] for op in c] for s, c in graph.items()})
    return best[problem.whole]


def search_counts(problem, truth: dict, pred: dict, r_opt: float,
                  beam_width: int | None = None) -> tuple[float, int]:
    """``(R / r_opt, operations scored)`` of ``SearchPlanner`` without simulations, planning on
    ``pred`` (key -> predicted score) and judged by ``truth`` (key -> simulated score); exact
    search unless ``beam_width`` is given (then always the beam)."""
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.scorer import Scorer
    from rap.plan.search.planner import SearchPlanner

    planner = (SearchPlanner(simulations=0, upper=0.0) if beam_width is None
               else SearchPlanner(beam_width=beam_width, max_operations=1, simulations=0, upper=0.0))
    result = planner.solve(problem, Scorer(LookupSimulator(truth), LookupCnn(pred), ScoreCache(), free_by_geometry=False))
    r = math.prod(truth[problem.key(s.operation)] for s in result.steps)
    return r / r_opt, int(result.stats["predicted_operations"])


def greedy_path(problem, graph: dict, truth: dict) -> dict:
    """Simulator-only greedy's path on ``truth`` (top down, the best-scoring candidate of each
    subassembly of ``graph``, the first on ties): ``decisions``, ``candidates`` (all scored along
    the path), ``no_high`` (decisions without a candidate >= ``HIGH``) and
    ``no_high_candidates`` (theirs)."""
    out = {"decisions": 0, "candidates": 0, "no_high": 0, "no_high_candidates": 0}
    stack = [problem.whole]
    while stack:
        s = stack.pop()
        if len(s) < 2:
            continue
        cands = graph[s]
        scores = [truth[problem.key(op)] for op in cands]
        out["decisions"] += 1
        out["candidates"] += len(cands)
        if max(scores) < HIGH:
            out["no_high"] += 1
            out["no_high_candidates"] += len(cands)
        op = cands[max(range(len(cands)), key=lambda i: (scores[i], -i))]
        stack += [op.moving, op.fixed]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("validation", "test", "unseen", "fresh"), default="unseen")
    ap.add_argument("--widths", default="1,2,4,8,16", help="beam widths to try with a perfect scorer")
    ap.add_argument("--per-assembly", action="store_true")
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    a = ap.parse_args()
    path = a.cache / f"{a.set}.pkl"
    if not path.exists():
        sys.exit(f"{path}: no score tables; run python -m research.search_validation --set {a.set}")
    tabs = pickle.loads(path.read_bytes())
    from rap.plan.graph import reachable

    rows = []
    for name, tab in tabs.items():
        problem = problem_of(name)  # its candidates are memoised: enumerated once
        truth = tab["truth"]
        graph = reachable(problem)
        r_opt = optimum(problem, graph, truth)
        _, model_ops = search_counts(problem, truth, tab["pred"], r_opt)
        r_perfect, perfect_ops = search_counts(problem, truth, truth, r_opt)
        g = greedy_path(problem, graph, truth)
        rows.append({"name": name, "problem": problem, "r_opt": r_opt, "operations": len(truth),
                     "model": model_ops, "perfect": perfect_ops, "r_perfect": r_perfect, **g})
        if a.per_assembly:
            print(f"{name:16s} operations {len(truth):6d}  exact search scores {model_ops:5d} "
                  f"(model) {perfect_ops:5d} (perfect)  greedy path {g['candidates']:4d}  "
                  f"no high candidate at {g['no_high']}/{g['decisions']} decisions "
                  f"({g['no_high_candidates']} candidates)")
    mean = statistics.mean
    print(f"{a.set}: {len(rows)} assemblies, {sum(r['operations'] for r in rows):,} operations")
    print("1. exact search, operations scored over greedy's path (per assembly, then averaged): "
          f"model {mean(r['model'] / r['candidates'] for r in rows):.1f}x, "
          f"perfect scorer {mean(r['perfect'] / r['candidates'] for r in rows):.1f}x "
          f"(range {min(r['perfect'] / r['candidates'] for r in rows):.1f}-"
          f"{max(r['perfect'] / r['candidates'] for r in rows):.1f}x); "
          f"perfect scorer's R / R opt {mean(r['r_perfect'] for r in rows):.3f}")
    print("2. beam with a perfect scorer:  width  R/R opt  worst  scored  over greedy's path")
    for w in (int(x) for x in a.widths.split(",")):
        res = [search_counts(r["problem"], tabs[r["name"]]["truth"], tabs[r["name"]]["truth"],
                             r["r_opt"], beam_width=w) for r in rows]
        print(f"{w:>36d} {mean(x for x, _ in res):8.3f} {min(x for x, _ in res):6.3f} "
              f"{mean(n for _, n in res):7.0f} "
              f"{mean(n / r['candidates'] for (_, n), r in zip(res, rows)):6.1f}x", flush=True)
    dec = sum(r["decisions"] for r in rows)
    nh = sum(r["no_high"] for r in rows)
    cands = sum(r["candidates"] for r in rows)
    nhc = sum(r["no_high_candidates"] for r in rows)
    print(f"3. simulator-only greedy's path: {nh} of {dec} decisions ({nh / dec:.0%}) have no "
          f"candidate >= {HIGH}; simulator-only simulates {cands} operations, a perfect "
          f"classifier's paper-rule fallback {nhc} of them ({cands / max(nhc, 1):.1f}x fewer), "
          f"and at least {nh} with one simulation per fallback ({cands / max(nh, 1):.1f}x fewer)")


if __name__ == "__main__":
    main()
