"""Benchmark: per-call cost of ``rap.sim.statics.check_static`` on subsets of the 22-brick wall.

Run: ``python benchmarks/statics.py [--subsets N] [--seed S]``. Loads
``assemblies/cells/brick-wall-22.json`` and checks, under gravity (0, -1) with the plate as the
base: every bottom-up prefix of the wall (brick by brick, course by course; all stable), then N
distinct random subsets (a seeded number of bricks chosen uniformly; mostly unstable). Each
subset is checked once with a cold result cache (the contact table and per-part data are built
once, timed separately), then once more (a cache hit). Prints the first-call cost (mean, median,
95th percentile) of stable and unstable subsets, and the cache hit's, in wall time and in the
process's CPU time (on a shared machine the CPU time is the closer to an idle machine's wall time;
the load average is printed).

Then the planner's use: ``rap.plan.graph.reachable`` on the wall with ``--base plate --gravity
0,-1`` (10,362 stability checks), timed with this check from a cold result cache, and again with
the check's answers looked up in a dict (the planner's own cost): the difference is the checks'
share (``--skip-reachable`` leaves this part out). Measured in one run on the shared 2-core
machine, the check before its rewrite over precomputed tables and HiGHS called directly (commit
4afe7b6, scipy's linprog) against after, interleaved twice: reachable() 20.9 and 21.2 s wall
before, 7.4 and 7.0 s after; the planner alone about 2.5 s, so the checks went from about 18.5 s
to 4.5 s (1.8 to 0.45 ms a check on average).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

from rap.geometry.contacts import contact_table
from rap.io import load_assembly
from rap.plan.cell.constraints import CellConstraints
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams
from rap.sim.statics import check_static, clear_results

WALL = Path(__file__).resolve().parents[1] / "assemblies" / "cells" / "brick-wall-22.json"


def _row(name: str, times: list[tuple[float, float]]) -> str:
    if not times:
        return f"{name:<24} (none)"
    out = f"{name:<24} n={len(times):<4}"
    for label, k in (("wall", 0), ("cpu", 1)):
        ms = sorted(t[k] * 1e3 for t in times)
        p95 = ms[min(len(ms) - 1, int(0.95 * len(ms)))]
        out += (f"  {label}: mean {statistics.fmean(ms):5.2f} median {statistics.median(ms):5.2f}"
                f" p95 {p95:5.2f} ms")
    return out


def _timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, (time.perf_counter() - w, time.process_time() - c)


def _reachable(wall, stability_fn) -> tuple[int, tuple[float, float]]:
    """reachable() on the wall under gravity: subassemblies, (wall, CPU) seconds."""
    cons = CellConstraints.parse("plate", False, None, "0,-1", None, False)
    problem = PlanningProblem(wall, SimParams(trials=10), constraints=cons)
    problem.stability_fn = stability_fn
    graph, t = _timed(lambda: reachable(problem, 20000))
    return len(graph), t


def _planner_rows(wall) -> None:
    clear_results()
    answers = {}

    def check(asm, ids, base, g, mu):
        answers[frozenset(ids)] = got = check_static(asm, ids, base, g, mu)
        return got

    n, t = _reachable(wall, check)
    checks = len(answers)
    print(f"reachable(), plate base, gravity (0, -1): {n} subassemblies, {checks} checks, "
          f"wall {t[0]:.2f} s, cpu {t[1]:.2f} s: {1e3 * t[1] / checks:.3f} ms cpu a check")
    _, t0 = _reachable(wall, lambda asm, ids, base, g, mu: answers[frozenset(ids)])
    print(f"the same with the checks' answers looked up: wall {t0[0]:.2f} s, cpu {t0[1]:.2f} s; "
          f"the checks: {t[1] - t0[1]:.2f} s cpu, {1e3 * (t[1] - t0[1]) / checks:.3f} ms a check")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--subsets", type=int, default=500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip-reachable", action="store_true")
    args = ap.parse_args()
    wall = load_assembly(WALL)
    bricks = sorted((p for p in wall.ids if p != "plate"),
                    key=lambda b: (int(b[1:].split("_")[0]), int(b.split("_b")[1])))
    t = time.perf_counter()
    contact_table(wall)
    check_static(wall, ["plate", bricks[0]], "plate", (0, -1))
    print(f"contact table and per-part data, once: {1e3 * (time.perf_counter() - t):.1f} ms")

    subsets = [frozenset(["plate", *bricks[:k]]) for k in range(2, len(bricks) + 1)]
    rng = np.random.default_rng(args.seed)
    seen = set(subsets)
    while len(subsets) < len(bricks) - 1 + args.subsets:
        k = int(rng.integers(1, len(bricks) + 1))
        s = frozenset(["plate", *rng.choice(bricks, size=k, replace=False).tolist()])
        if s not in seen:
            seen.add(s)
            subsets.append(s)

    cold = {True: [], False: []}
    hot = []
    for s in subsets:
        verdict, t = _timed(lambda: check_static(wall, s, "plate", (0, -1)))
        cold[verdict.stable].append(t)
        hot.append(_timed(lambda: check_static(wall, s, "plate", (0, -1)))[1])
    print(_row("first call, stable", cold[True]))
    print(_row("first call, not stable", cold[False]))
    print(_row("first call, all", cold[True] + cold[False]))
    print(_row("cache hit", hot))
    if not args.skip_reachable:
        _planner_rows(wall)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
