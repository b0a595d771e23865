"""Benchmark of ``rap-farm export``: the 22-brick wall's plan to a program, and its kinematic check.

Prints the median wall time over ``--repeat`` runs of (1) building the program from the plan
(``rap.robot.program.build_program``: grasps, tray, 176 waypoints) and writing its waypoints as
CSV and JSON (the arms' own formats: ``benchmarks/robot_arms.py``), with the plan and assembly already read; (2) reading the plan and the
assembly; (3) the kinematic check (``rap.robot.kinematics.check_program``: every waypoint and
every linear segment at 8 points, about 970 IK solves), with and without opening the pybullet
world; and the solve rate. Targets of issue 39: export under 1 s, the check under 2 s.

    python benchmarks/robot_export.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.robot.cell import Cell  # noqa: E402
from rap.robot.inputs import load_plan_and_assembly  # noqa: E402
from rap.robot.kinematics import IkSolver, check_program  # noqa: E402
from rap.robot.program import build_program  # noqa: E402
from rap.robot.arms.export import render  # noqa: E402
from rap.robot.cell import with_  # noqa: E402

PLAN = ROOT / "tests" / "robot" / "data" / "brick-wall-22.plan.json"
ASSEMBLY = ROOT / "assemblies" / "cells" / "brick-wall-22.json"


CPU = {}


def timed(fn, repeat):
    """Median wall seconds of ``fn()`` and its last result; the median CPU seconds of this
    process go to ``CPU[fn]`` (the machine is shared: CPU time is what the work costs)."""
    times, cpus, out = [], [], None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    CPU[fn] = statistics.median(cpus)
    return statistics.median(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    read = lambda: load_plan_and_assembly(PLAN, ASSEMBLY)  # noqa: E731
    t_read, (plan, _doc, asm) = timed(read, args.repeat)
    with tempfile.TemporaryDirectory() as tmp:
        def export():  # the waypoints (no kinematics); the arms' own formats: robot_arms.py
            prog = build_program(plan, asm, Cell())
            (Path(tmp) / "wall.csv").write_text(render(prog, "waypoints-csv", None))
            (Path(tmp) / "wall.json").write_text(render(prog, "waypoints-json", None))
            render(build_program(plan, asm, with_(Cell(), "robot", arm="ur5e")),
                   "waypoints-json", None)
            return prog

        t_export, prog = timed(export, args.repeat)
    check = lambda: check_program(prog)  # noqa: E731
    t_check, report = timed(check, args.repeat)
    solver = IkSolver(tool_offset_m=Cell().gripper.tool_offset_m)
    warm = lambda: check_program(prog, solver)  # noqa: E731
    t_warm, _ = timed(warm, args.repeat)
    solver.close()
    print(f"plan: {PLAN.name}, {len(prog.steps)} steps, {len(prog.waypoints)} waypoints")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; median of "
          f"{args.repeat}: wall (CPU of this process)")
    print(f"read plan + assembly          {t_read * 1e3:8.1f} ms ({CPU[read] * 1e3:.1f} ms CPU)")
    print(f"build program + write twice   {t_export * 1e3:8.1f} ms ({CPU[export] * 1e3:.1f} ms CPU)"
          f"   target: export < 1 s")
    print(f"kinematic check, cold world   {t_check * 1e3:8.1f} ms ({CPU[check] * 1e3:.1f} ms CPU)"
          f"   target: < 2 s")
    print(f"kinematic check, warm world   {t_warm * 1e3:8.1f} ms ({CPU[warm] * 1e3:.1f} ms CPU)"
          f"   {report.solves} IK solves, {CPU[warm] / report.solves * 1e6:.0f} us CPU a solve, "
          f"worst error {report.worst_position_m * 1e3:.3f} mm")
    print(f"export with check (CLI work)  {(t_read + t_export + t_check) * 1e3:8.1f} ms")


if __name__ == "__main__":
    main()
