"""Whole-plan rollouts on 1 and 2 workers: the same figures, and the speed-up (issue 46).

    python benchmarks/rollouts_scaling.py [--rollouts 200] [--ray]

Runs the 22-brick wall's plan (tests/robot/data) ``--rollouts`` times under the shipped cell's
errors with the local simulator's worker processes (1, then 2), and with ``--ray`` on a local Ray
pool of 1, then 2 actors (``rap.farm.rollouts``). Prints the seconds, the speed-up 1 -> 2 measured
in this run, and checks the successes are identical. Needs 2 free cores to show the speed-up.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=200)
    ap.add_argument("--ray", action="store_true")
    args = ap.parse_args()
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.execution.rollout import RolloutPlan
    from rap.execution.sequence import measure
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell
    from rap.robot.inputs import load_plan_and_assembly
    from rap.sim.params import DEFAULT_PARAMS

    plan, _, asm = load_plan_and_assembly(ROOT / "tests/robot/data/brick-wall-22.plan.json",
                                          ROOT / "assemblies/cells/brick-wall-22.json")
    cell = Cell()
    rplan = RolloutPlan(tuple(s.to_operation() for s in plan.steps), DEFAULT_PARAMS,
                        cell_errors(cell), mm_per_unit(cell, asm))

    def timed(runner):
        measure(asm, rplan, runner, 1, rollouts=25)  # warm: the workers load the simulator
        t = time.perf_counter()
        out = measure(asm, rplan, runner, 0, rollouts=args.rollouts)
        return time.perf_counter() - t, out.success

    rows = []
    for workers in (1, 2):
        sim = LocalSimulator(processes=workers, prestart=workers > 1)
        try:
            rows.append(("local processes", workers, *timed(sim)))
        finally:
            sim.close()
    if args.ray:
        import ray

        from rap.farm.pool import SimPool
        from rap.farm.rollouts import PoolRollouts

        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            for workers in (1, 2):
                with SimPool(workers) as pool:
                    pool.ready(timeout_s=120, at_least=workers)
                    rows.append(("Ray pool actors", workers, *timed(PoolRollouts(pool))))
        finally:
            ray.shutdown()
    print("| runner | workers | seconds | success |")
    print("|---|---:|---:|---|")
    for kind, w, s, r in rows:
        print(f"| {kind} | {w} | {s:.1f} | {r.text()} |")
    for kind in dict.fromkeys(k for k, *_ in rows):
        one, two = [r for r in rows if r[0] == kind]
        same = "identical" if one[3] == two[3] else "DIFFERENT"
        print(f"{kind}: 1 -> 2 workers {one[2] / two[2]:.2f}x faster; results {same}")


if __name__ == "__main__":
    main()
