"""``rap-farm export PLAN.json -o FILE [--format F] [--arm A] [--cell C] [--assembly A]``.

Turns a plan (``rap-farm plan --out``) into one arm's program (``rap.robot.program``) in the
robot cell (``--cell``; the shipped ``rap/robot/default_cell.toml`` when left out; ``--arm``
replaces its ``[robot] arm``), checks it with that arm's kinematics, and only then writes it
atomically (``rap.robot.arms.export``). Formats (``rap.robot.arms.registry.FORMATS``, the arm
must take it): ``urscript`` (UR arms: joint-target ``movej`` on one IK branch, ``movel`` with
blend 0, ``set_tcp``, ``set_target_payload``), ``joint-trajectory-yaml`` / ``-json`` (the Panda:
ROS 2 JointTrajectory segments within its velocity, acceleration and jerk limits),
``waypoints-csv`` / ``-json`` (any arm). ``--format`` defaults by FILE's suffix: ``.script``
URScript, ``.csv``/``.json`` waypoints, ``.yaml`` a joint trajectory. The plan does not carry the
geometry: ``--assembly`` gives it (default: ``NAME.json`` beside the plan, ``rap.robot.inputs``).

Exit status: 0 written; 1 the plan cannot be built by one arm in this cell (a two-handed step, or
a point out of reach: the step, the point and the limit named), nothing written; 2 bad input
(the plan, the assembly, the cell file, an unknown arm, a format unknown or not the arm's: one
line); 3 the file cannot be written.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register", "export_command"]


def export_command(
    plan: Path = typer.Argument(..., metavar="PLAN.json", help="A plan from rap-farm plan --out."),
    out: Path = typer.Option(..., "-o", "--out", help="The program file to write."),
    fmt: str = typer.Option(None, "--format",
                            help="urscript (UR arms) | joint-trajectory-yaml | "
                                 "joint-trajectory-json (Panda) | waypoints-csv | waypoints-json "
                                 "[default: by the file's suffix: .script urscript, .csv/.json "
                                 "waypoints, .yaml joint trajectory]"),
    arm: str = typer.Option(None, "--arm", help="panda | ur5e | ur10e [default: the cell's "
                                                "[robot] arm]"),
    cell: Path = typer.Option(None, "--cell", help="Robot cell TOML [default: the shipped cell, "
                                                   "rap/robot/default_cell.toml]."),
    assembly: Path = typer.Option(None, "--assembly",
                                  help="The plan's assembly file [default: NAME.json beside the "
                                       "plan]."),
    no_check: bool = typer.Option(False, "--no-check", help="Skip the kinematic check."),
) -> None:
    """Export a plan as the arm's robot program, checked by the arm's kinematics."""
    import time

    from rap.robot import export_program

    t0 = time.perf_counter()
    program, report, fmt = export_program(plan, out, fmt, cell=cell, assembly=assembly,
                                          check=not no_check, arm=arm)
    n = len(program.waypoints)
    branch = f", IK branch {report.branch}" if report is not None and report.branch else ""
    checked = ("not checked (--no-check)" if report is None else
               f"every one reached by the {program.cell.robot.arm} ({report.solves} points "
               f"solved, worst error {report.worst_position_m * 1e3:.3f} mm{branch}, "
               f"{report.seconds:.2f} s)")
    typer.echo(f"{out}: {fmt}, {len(program.steps)} steps, {n} waypoints, {program.frame.plane} "
               f"plane, fixture {program.fixture}; {checked}; "
               f"{time.perf_counter() - t0:.2f} s in all")


def register(app: typer.Typer) -> None:
    app.command("export")(export_command)
