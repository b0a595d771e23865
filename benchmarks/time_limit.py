"""The search's time limit: how far past ``--time-limit S`` a plan comes back, and what it is worth.

    python benchmarks/time_limit.py [--assemblies wall:22,grid:49,grid:100] [--limits 5,10,20]

For each assembly (``benchmarks/plan_scale.py``'s, seed 0) and each limit, the default plans with
``time_limit`` (``rap.plan.plan(..., time_limit=S)``, simulations in this process, a fresh cache a
plan, planning seed 11, 100 trials), after simulator-only greedy without one. Printed per plan: the
limit, the planning time (``PlanResult.seconds``) and its overshoot past the limit, the wall time
(search, the evaluation of the returned plan's steps, its bound), why the search stopped, whether
greedy's start finished within its share (0.8 of the limit; else the model chose its levels
left), R and R / greedy's R. The slack is
stated, not asserted: the limit is checked between rounds of simulations (and greedy's start
between its levels), so a plan can come back up to one round (two simulations), one greedy level
and the last DP later; the evaluation and the bound follow it. The CPU count and load average are
printed: times depend on what else runs.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from benchmarks.plan_scale import build  # noqa: E402


def main(argv=None) -> list[dict]:
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan import plan
    from rap.sim.params import SimParams

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assemblies", default="wall:22,grid:49,grid:100")
    ap.add_argument("--limits", default="5,10,20", help="comma-separated seconds")
    ap.add_argument("--seed", type=int, default=11)
    a = ap.parse_args(argv)
    params = SimParams()
    print(f"time_limit: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at start")
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    plan(build("grid", 4), model=model, seed=a.seed, params=SimParams(trials=2))  # warm-up
    print("| assembly | parts | limit s | plan s | over s | wall s | stopped | greedy start | R | "
          "R / greedy's |")
    print("|---|---:|---:|---:|---:|---:|---|---|---:|---:|")
    rows = []
    for spec in a.assemblies.split(","):
        kind, n = spec.split(":")
        asm = build(kind, int(n))
        greedy = plan(asm, "sim", seed=a.seed, params=params)
        for limit in (float(x) for x in a.limits.split(",")):
            t = time.perf_counter()
            r = plan(asm, model=model, seed=a.seed, params=params, time_limit=limit)
            wall = time.perf_counter() - t
            st = r.stats
            greedy_start = ("none" if not st.get("greedy_steps") else
                            f"{st['greedy_by_model']} by the model" if st.get("greedy_by_model")
                            else "done")
            row = {"assembly": spec, "parts": len(asm), "limit": limit, "seconds": r.seconds,
                   "over": r.seconds - limit, "wall": wall, "stopped": st.get("stopped"),
                   "greedy": greedy_start,
                   "R": r.robustness, "ratio": r.robustness / greedy.robustness}
            rows.append(row)
            print(f"| {kind} | {n} | {limit:g} | {r.seconds:.1f} | {row['over']:+.1f} | "
                  f"{wall:.1f} | {row['stopped']} | {row['greedy']} | {r.robustness:.3g} | "
                  f"{row['ratio']:.2f} |", flush=True)
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    return rows


if __name__ == "__main__":
    main()
