"""From plan to robot: a cell, one arm's program, its kinematic check and its execution.

A layer above ``rap.plan`` (it reads plans, never makes them) and below the farm: no Ray here.
Rooms, one idea each:

* ``cell``: the TOML cell file and its shipped defaults (``default_cell.toml``);
* ``frames``: the assembly's plane in the robot's base frame; ``grasp``: the cup on each part and
  the tray; ``program``: the waypoints of a plan; ``writers``: URScript, CSV, JSON;
* ``arm``: the arm models (pybullet_data's Panda); ``kinematics``: the reach check;
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


def export_program(plan_path, out, fmt: str, *, cell=None, assembly=None, check: bool = True):
    """Read the plan (and its assembly) and the cell, build the program, check it with the arm's
    kinematics (unless ``check`` is False), and write it to ``out`` in ``fmt`` (``urscript`` or
    ``waypoints``) atomically. Returns ``(program, KinematicReport | None)``.

    Raises ``InputError`` (exit 2: bad plan, assembly or cell), ``TwoHandedPlan`` or
    ``Unreachable`` (exit 1; nothing written), ``StorageError`` (exit 3). Cost: the program in
    O(waypoints), the check about 0.2 ms a solve (``rap.robot.kinematics``)."""
    from rap.errors import StorageError
    from rap.robot.cell import load_cell
    from rap.robot.inputs import load_plan_and_assembly
    from rap.robot.program import build_program
    from rap.robot.writers import write_program

    plan, _doc, asm = load_plan_and_assembly(plan_path, assembly)
    program = build_program(plan, asm, load_cell(cell))
    report = None
    if check:
        from rap.robot.kinematics import check_program

        report = check_program(program)
    try:
        write_program(program, Path(out), fmt)
    except OSError as exc:
        raise StorageError(f"-o {out}: cannot write ({exc.strerror or exc}); nothing written"
                           ) from None
    return program, report
