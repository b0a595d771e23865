"""Benchmark of the arms of issue 47: the UR5e's FK vector, the IK round trip on 10,000 seeded
poses, and for each shipped robot plan (tests/robot/data: the stack, the tangram, the 22-brick
wall) on the UR5e, the UR10e and the Panda: the kinematic check's and the export's seconds (the
format each arm takes first: URScript, the YAML joint trajectory), the Panda trajectory's
largest velocity, acceleration and jerk against its limits (sampled every 1 ms), and the branch.

    python benchmarks/robot_arms.py [--skip-wall]

Targets (issue 47): FK within 0.1 mm; IK round trip under 1e-6 m; each example exported in
under 1 s and checked in under 2 s; the trajectory within the Panda's limits (ratios <= 1).
Wall times on a shared machine: the CPU time of this process is printed beside them.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.robot.arms import ur  # noqa: E402
from rap.robot.arms.export import check_arm, render  # noqa: E402
from rap.robot.arms.registry import ARMS  # noqa: E402
from rap.robot.arms.trajectory import limit_ratios, plan_trajectory  # noqa: E402
from rap.robot.cell import Cell, with_  # noqa: E402
from rap.robot.inputs import load_plan_and_assembly  # noqa: E402
from rap.robot.program import build_program  # noqa: E402

DATA = ROOT / "tests" / "robot" / "data"
EXAMPLES = [("stack", DATA / "stack.plan.json", ROOT / "assemblies/cells/stack.json"),
            ("tangram", DATA / "tangram.plan.json", ROOT / "assemblies/unseen/tangram.json"),
            ("brick-wall-22", DATA / "brick-wall-22.plan.json",
             ROOT / "assemblies/cells/brick-wall-22.json")]


def timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-wall", action="store_true")
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; wall (CPU) seconds")
    T = ur.fk(ARMS["ur5e"].dh, np.zeros(6))
    print(f"UR5e FK at q = 0: flange at ({T[0, 3]:.4f}, {T[1, 3]:.4f}, {T[2, 3]:.4f}) m, "
          f"off the maker's (-0.8172, -0.2329, 0.0628) by "
          f"{np.abs(T[:3, 3] - [-0.8172, -0.2329, 0.0628]).max() * 1e3:.4f} mm")
    for name in ("ur5e", "ur10e"):
        spec = ARMS[name]
        q = np.random.default_rng(47).uniform(-np.pi, np.pi, (10_000, 6))
        Tq = ur.fk(spec.dh, q)
        sols, wall, cpu = timed(lambda: ur.solutions(spec, Tq))
        ok = ~np.isnan(sols[..., 0])
        back = ur.fk(spec.dh, np.nan_to_num(sols))
        err = np.linalg.norm(back[..., :3, 3] - Tq[:, None, :3, 3], axis=-1)[ok]
        print(f"{name} IK round trip, 10,000 seeded poses (seed 47), {int(ok.sum())} solutions:"
              f" max error {err.max():.2e} m; {wall:.2f} s ({cpu:.2f} s CPU)")
    for ex, plan_path, asm_path in EXAMPLES:
        if args.skip_wall and ex.startswith("brick"):
            continue
        plan, _, asm = load_plan_and_assembly(plan_path, asm_path)
        for arm in ("ur5e", "ur10e", "panda"):
            prog = build_program(plan, asm, with_(Cell(), "robot", arm=arm))
            report, t_check, c_check = timed(lambda: check_arm(prog))
            fmt = ARMS[arm].formats[0]
            text, t_write, c_write = timed(lambda: render(prog, fmt, report))
            extra = f"branch {report.branch}" if report.branch else ""
            if arm == "panda":
                v, a, j = limit_ratios(plan_trajectory(prog, report), 0.001)
                extra = f"trajectory max |qd|/V {v:.3f}, |qdd|/A {a:.3f}, |qddd|/J {j:.3f}"
            print(f"{ex:14s} {arm:6s} {len(prog.waypoints):4d} waypoints, {report.solves:5d} "
                  f"points: check {t_check:.2f} s ({c_check:.2f}), {fmt} {t_write:.2f} s "
                  f"({c_write:.2f}), {len(text) / 1e3:.0f} kB; {extra}")


if __name__ == "__main__":
    main()
