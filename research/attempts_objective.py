"""Robustness or attempts: does the optimum change when it minimises the expected attempts?

For each assembly, every operation simulated (100 trials), the optimum twice over the same scores:
R's (the optimal planner: the product of the step scores, maximised) and the expected attempts'
(when a failed step is retried until it succeeds, the sum of 1/r, minimised:
``rap.plan.dp.dp_choice(..., objective="attempts")``). Printed per assembly: whether the plans differ, and R,
the expected attempts and the expected failed steps (the sum of 1 - r) of each.

    python -m research.attempts_objective                     # both sets below, a few minutes
    python -m research.attempts_objective --set unseen --names tangram,wall-s101
    python -m research.attempts_objective --set none --scale wall:22 --max-operations 9000

The sets: the unseen assemblies (``datasets/splits.json``) whose graphs have at most
``--max-operations`` operations (default 800: five of twelve), and the small assemblies of
``benchmarks/plan_scale.py`` (``assemblies_for``, up to 12 parts, at most ``--max-operations``;
raise it for larger ones, e.g. ``--scale grid:25 --max-operations 9000``: about 10 minutes on 2
cores).
Scores come from ``research.search_validation``'s tables where they are cached (no simulation),
else are simulated here on ``--workers`` processes and kept in ``--cache`` (a score cache file), so
a second run simulates nothing.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from research.validation_tables import ROOT, LookupSimulator, assemblies_of, problem_of

#: the small assemblies of benchmarks/plan_scale.py where the optimum is computed (up to 12 parts)
SCALE_SMALL = "herringbone:7,packing:8,grid:9,polyomino:10,wall:12"
SCALE_SEED = 11  # benchmarks/plan_scale.py's planning seed (--seed): the same scores


def compare(problem, simulator, cache) -> dict:
    """The optimum of each objective on ``problem``: objective -> {plan keys, R, attempts,
    failures}, and ``same`` (the same steps). R's optimum is the optimal planner's plan; the
    attempts' optimum is ``rap.plan.dp.dp_choice(..., objective="attempts")`` over the same
    simulated scores (read back from ``cache``)."""
    from rap.plan import plan
    from rap.plan.dp import dp_choice, dp_tree
    from rap.plan.graph import reachable
    from rap.plan.scoring.scorer import Scorer
    from rap.stats import expected_attempts

    r = plan(problem, "optimal", simulator=simulator, cache=cache)
    if not r.found:
        return {"status": r.message}
    graph = reachable(problem)
    flat = [op for c in graph.values() for op in c]
    scores = iter(Scorer(simulator, None, cache).scores(problem, flat))  # cache hits
    score_of = {s: [next(scores) for _ in c] for s, c in graph.items()}
    _, arg = dp_choice(graph, score_of, objective="attempts")
    tree = dp_tree(graph, arg, problem.whole)
    tries = [score_of[s][i] for s, (i, _) in tree.items()]
    out: dict = {
        "robustness": {"plan": sorted(problem.key(s.to_operation()) for s in r.steps),
                       "R": r.robustness, "attempts": r.expected_attempts,
                       "failures": r.expected_failures, "steps": len(r.steps)},
        "attempts": {"plan": sorted(problem.key(op) for _, op in tree.values()),
                     "R": math.prod(tries), "attempts": sum(map(expected_attempts, tries)),
                     "failures": sum(1.0 - x for x in tries), "steps": len(tries)}}
    out["same"] = out["robustness"]["plan"] == out["attempts"]["plan"]
    return out


def _operations(problem, limit: int) -> int | None:
    from rap.plan.graph import TooLarge, reachable

    try:
        return sum(map(len, reachable(problem, limit).values()))
    except TooLarge:
        return None


def _small(problem, limit: int) -> bool:
    return (_operations(problem, limit) or math.inf) <= limit


def _cached_truth(cache_dir: Path, split: str) -> dict:
    """name -> simulated scores from ``research.search_validation``'s cached tables, if any."""
    import pickle

    path = cache_dir / f"{split}.pkl"
    return {n: t["truth"] for n, t in pickle.loads(path.read_bytes()).items()} \
        if path.exists() else {}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("unseen", "fresh", "none"), default="unseen")
    ap.add_argument("--names", help="comma-separated names of the set (default: those small "
                                    "enough)")
    ap.add_argument("--scale", default=SCALE_SMALL,
                    help="plan_scale assemblies KIND:N,... ('' for none)")
    ap.add_argument("--max-operations", type=int, default=800)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--tables", type=Path, default=ROOT / "reports" / "search-validation",
                    help="research.search_validation's cache of score tables")
    ap.add_argument("--cache", type=Path,
                    default=ROOT / "reports" / "attempts-objective" / "scores.json")
    a = ap.parse_args(argv)

    from benchmarks.plan_scale import assemblies_for
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.sim.params import SimParams

    cases = []  # (label, problem, simulator or None)
    if a.set != "none":
        truth = _cached_truth(a.tables, a.set)
        names = a.names.split(",") if a.names else assemblies_of(a.set)
        for n in names:
            problem = problem_of(n)
            if n in truth:
                cases.append((n, problem, LookupSimulator(truth[n])))
            elif a.names or _small(problem, a.max_operations):
                cases.append((n, problem, None))
    for spec in filter(None, a.scale.split(",")):
        kind, n = spec.split(":")
        for _, _, asm in assemblies_for([kind], [int(n)]):
            if isinstance(asm, str):
                print(f"{spec}: skipped ({asm})")
                continue
            problem = PlanningProblem(asm, SimParams(), SCALE_SEED)
            if _small(problem, a.max_operations):
                cases.append((asm.name[:28], problem, None))
            else:
                print(f"{spec}: skipped (over --max-operations {a.max_operations})")

    a.cache.parent.mkdir(parents=True, exist_ok=True)
    cache = ScoreCache(a.cache)
    sim = LocalSimulator(processes=a.workers, min_batch=1)
    print(f"{'assembly':<28} {'parts':>5} {'ops':>5} {'same':>5} {'R (R)':>7} {'R (A)':>7} "
          f"{'att (R)':>8} {'att (A)':>8} {'fail (R)':>8} {'fail (A)':>8}")
    rows = []
    try:
        for label, problem, lookup in cases:
            row = compare(problem, lookup or sim, cache)
            cache.flush()
            if "same" not in row:
                print(f"{label:<28} {row['status']}")
                continue
            rows.append(row)
            rr, aa = row["robustness"], row["attempts"]
            print(f"{label:<28} {len(problem.whole):>5} {_operations(problem, 10**6):>5} "
                  f"{'yes' if row['same'] else 'NO':>5} {rr['R']:7.4f} {aa['R']:7.4f} "
                  f"{rr['attempts']:8.3f} {aa['attempts']:8.3f} {rr['failures']:8.3f} "
                  f"{aa['failures']:8.3f}", flush=True)
    finally:
        sim.close()
    differ = [r for r in rows if not r["same"]]
    print(f"plans differ on {len(differ)} of {len(rows)} assemblies")
    for r in differ:
        rr, aa = r["robustness"], r["attempts"]
        print(f"  R of the attempts plan / R of the robustness plan {aa['R'] / rr['R']:.4f}; "
              f"attempts saved {rr['attempts'] - aa['attempts']:.4f} "
              f"({(rr['attempts'] - aa['attempts']) / rr['attempts']:.2%})")


if __name__ == "__main__":
    main()
