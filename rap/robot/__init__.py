"""From plan to robot: a cell, one arm's program, its kinematic check and its execution.

A layer above ``rap.plan`` (it reads plans, never makes them) and below the farm: no Ray here.
Rooms, one idea each:

* ``cell``: the TOML cell file and its shipped defaults (``default_cell.toml``);
* ``frames``: the assembly's plane in the robot's base frame; ``grasp``: the cup on each part and
  the tray; ``program``: the waypoints of a plan; ``writers``: waypoints as CSV, JSON;
* ``arms/``: the arm registry (``arms.registry``: every arm's kinematics, limits, reach,
  repeatability and formats; the one export vocabulary), the UR arms' analytic kinematics, check,
  URScript and pybullet model, the Panda's joint trajectory (Ruckig) and its ROS 2 writer, and
  ``arms.export``, the door from a program to a checked file for its arm;
* ``arm``: the Panda's pybullet model; ``kinematics``: the Panda's reach check;
* ``arm_sim``: the program run on the arm in pybullet; ``planar``: the whole plan run in the
  planar simulator with each step starting where the previous ones left the parts;
  ``trials``: success counts and their intervals; ``gif``: pictures of the arm run;
* ``inputs``: a plan document and the assembly it names.

Front door for the CLI, a service or a script: ``export_program`` (below). pybullet is imported
only by ``arm``, ``kinematics`` and ``arm_sim``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["export_program"]


def export_program(plan_path, out, fmt: str | None = None, *, cell=None, assembly=None,
                   check: bool = True, arm: str | None = None):
    """Read the plan (and its assembly) and the cell (``arm``, when given, replaces its ``[robot]
    arm``), build the program, check it with the arm's kinematics (unless ``check`` is False: the
    waypoint formats only), and write it to ``out`` in ``fmt`` (one of
    ``rap.robot.arms.registry.FORMATS`` that the arm takes; None: by ``out``'s suffix,
    ``format_for_suffix``) atomically. Returns ``(program, KinematicReport | None, fmt)``.

    Raises ``InputError`` (exit 2: bad plan, assembly, cell, arm, or a format the arm does not
    take), ``TwoHandedPlan`` or ``Unreachable`` (exit 1; nothing written), ``StorageError`` (exit
    3). Cost: the program in O(waypoints), then ``rap.robot.arms.export``'s check and writer."""
    from dataclasses import replace

    from rap.errors import StorageError
    from rap.files import write_text_atomic
    from rap.robot.arms.export import export_text
    from rap.robot.arms.registry import arm_spec, check_format, format_for_suffix
    from rap.robot.cell import load_cell
    from rap.robot.inputs import load_plan_and_assembly
    from rap.robot.program import build_program

    out = Path(out)
    the_cell = load_cell(cell)
    if arm is not None:
        arm_spec(arm, "--arm")
        the_cell = replace(the_cell, robot=replace(the_cell.robot, arm=arm))
    fmt = fmt or format_for_suffix(the_cell.robot.arm, out.suffix)
    check_format(the_cell.robot.arm, fmt, "--format")
    plan, _doc, asm = load_plan_and_assembly(plan_path, assembly)
    program = build_program(plan, asm, the_cell)
    text, report = export_text(program, fmt, check, "--format")
    try:
        write_text_atomic(out, text, newline="" if fmt == "waypoints-csv" else None)
    except OSError as exc:
        raise StorageError(f"-o {out}: cannot write ({exc.strerror or exc}); nothing written"
                           ) from None
    return program, report, fmt
