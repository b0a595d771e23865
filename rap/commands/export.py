"""``rap-farm export PLAN.json -o FILE [--format urscript|waypoints] [--cell C] [--assembly A]``.

Turns a plan (``rap-farm plan --out``) into one arm's program (``rap.robot.program``) in the
robot cell (``--cell``; the shipped ``rap/robot/default_cell.toml`` when left out), checks it
with the arm's inverse kinematics (``rap.robot.kinematics``), and only then writes it
atomically: URScript (``movej``/``movel`` to ``p[...]`` poses, the vacuum on a digital output)
or waypoints (CSV when FILE ends in ``.csv``, else JSON). ``--format`` defaults to ``urscript``
for ``.script``/``.urscript`` files, else ``waypoints``. The plan does not carry the geometry:
``--assembly`` gives it (default: ``NAME.json`` beside the plan, ``rap.robot.inputs``).

Exit status: 0 written; 1 the plan cannot be built by one arm in this cell (a two-handed step, or
a waypoint out of reach: the step, the point and the limit named), nothing written; 2 bad input
(the plan, the assembly, the cell file: one line naming the key); 3 the file cannot be written.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register", "export_command"]


def export_command(
    plan: Path = typer.Argument(..., metavar="PLAN.json", help="A plan from rap-farm plan --out."),
    out: Path = typer.Option(..., "-o", "--out", help="The program file to write."),
    fmt: str = typer.Option(None, "--format",
                            help="urscript | waypoints (CSV for .csv, else JSON) [default: by "
                                 "the file's suffix: .script/.urscript -> urscript]"),
    cell: Path = typer.Option(None, "--cell", help="Robot cell TOML [default: the shipped cell, "
                                                   "rap/robot/default_cell.toml]."),
    assembly: Path = typer.Option(None, "--assembly",
                                  help="The plan's assembly file [default: NAME.json beside the "
                                       "plan]."),
    no_check: bool = typer.Option(False, "--no-check", help="Skip the kinematic check."),
) -> None:
    """Export a plan as a robot program (URScript or waypoints), checked by the arm's kinematics."""
    import time

    from rap.errors import InputError
    from rap.robot import export_program

    if fmt is None:
        fmt = "urscript" if out.suffix.lower() in (".script", ".urscript") else "waypoints"
    if fmt not in ("urscript", "waypoints"):
        raise InputError(f"--format {fmt!r}: choose urscript or waypoints")
    t0 = time.perf_counter()
    program, report = export_program(plan, out, fmt, cell=cell, assembly=assembly,
                                     check=not no_check)
    n = len(program.waypoints)
    checked = ("not checked (--no-check)" if report is None else
               f"every one reached by the {program.cell.robot.arm} ({report.solves} IK solves, "
               f"worst error {report.worst_position_m * 1e3:.3f} mm, {report.seconds:.2f} s)")
    typer.echo(f"{out}: {fmt}, {len(program.steps)} steps, {n} waypoints, {program.frame.plane} "
               f"plane, fixture {program.fixture}; {checked}; "
               f"{time.perf_counter() - t0:.2f} s in all")


def register(app: typer.Typer) -> None:
    app.command("export")(export_command)
