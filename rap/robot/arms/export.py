"""The front door from a program to a file for its cell's arm: check it, then write the format.

``check_arm(program)`` runs the arm's kinematic check: a UR arm's analytic check on one IK branch
(``rap.robot.arms.ur_check``), the Panda's pybullet check (``rap.robot.kinematics``). Both raise
``Unreachable`` (exit 1) naming the step, the waypoint, the point and the limit, and return a
``KinematicReport`` with the joint vectors of every waypoint and every sample.

``render(program, fmt, report)`` writes ``fmt`` (one of ``registry.FORMATS``, which the arm must
take: ``registry.check_format``, an ``InputError``, exit 2, otherwise):

* ``urscript`` (UR arms): ``rap.robot.arms.urscript``, joint targets from the report;
* ``joint-trajectory-yaml`` / ``-json`` (the Panda): ``rap.robot.arms.trajectory`` times the
  report's joint paths with Ruckig, ``rap.robot.arms.ros`` writes ROS 2 JointTrajectory segments;
* ``waypoints-csv`` / ``-json`` (any arm): ``rap.robot.writers``; these alone can be written
  without the check (``report`` None).

``export_text(program, fmt, check=True)`` does both and returns ``(text, report)``. Cost: the
check's (UR: about 60 us a point, 1 mm apart; Panda: about 0.3 ms a point, 5 mm apart) plus
O(waypoints) or, for a trajectory, O(its duration / 20 ms).
"""

from __future__ import annotations

from rap.errors import InputError
from rap.robot.arms.registry import arm_spec, check_format
from rap.robot.kinematics import KinematicReport
from rap.robot.program import Program

__all__ = ["check_arm", "render", "export_text", "NEEDS_CHECK"]

#: formats written from the check's joint vectors
NEEDS_CHECK = ("urscript", "joint-trajectory-yaml", "joint-trajectory-json")


def check_arm(program: Program) -> KinematicReport:
    """The kinematic check of ``program`` on its cell's arm (module doc)."""
    spec = arm_spec(program.cell.robot.arm)
    if spec.kinematics == "dh":
        from rap.robot.arms.ur_check import check_ur

        return check_ur(program)
    from rap.robot.kinematics import check_program

    return check_program(program)


def render(program: Program, fmt: str, report: KinematicReport | None,
           where: str = "format") -> str:
    """The text of ``program`` in ``fmt`` for its cell's arm (module doc)."""
    check_format(program.cell.robot.arm, fmt, where)
    if fmt == "waypoints-csv":
        from rap.robot.writers import waypoints_csv

        return waypoints_csv(program)
    if fmt == "waypoints-json":
        from rap.robot.writers import waypoints_json

        return waypoints_json(program)
    if report is None:
        raise InputError(f"{where} {fmt!r} is written from the kinematic check's joint targets: "
                         f"leave out --no-check")
    if fmt == "urscript":
        from rap.robot.arms.urscript import urscript

        return urscript(program, report)
    from rap.robot.arms.ros import trajectory_json, trajectory_yaml
    from rap.robot.arms.trajectory import plan_trajectory

    trajectory = plan_trajectory(program, report)
    return (trajectory_yaml if fmt.endswith("yaml") else trajectory_json)(program, trajectory)


def export_text(program: Program, fmt: str, check: bool = True,
                where: str = "format") -> tuple[str, KinematicReport | None]:
    """``(render(program, fmt, report), report)`` after ``check_arm`` (module doc); the format
    is checked against the arm first, so a refusal costs no kinematics."""
    check_format(program.cell.robot.arm, fmt, where)
    if not check and fmt in NEEDS_CHECK:
        raise InputError(f"{where} {fmt!r} is written from the kinematic check's joint targets: "
                         f"leave out --no-check")
    report = check_arm(program) if check else None
    return render(program, fmt, report, where), report
