"""The kinematic check: every waypoint and every point of a linear segment within the arm's reach.

``check_program(program)`` solves the arm's inverse kinematics (pybullet's damped-least-squares
solver, ``calculateInverseKinematics``, on the cell's arm model, ``rap.robot.arm``) for every
waypoint in program order, the tool pointing down, each solve warm-started from the previous
solution. A ``movel`` segment is checked at ``motion.samples_per_segment`` evenly spaced points
(ends included), and at most ``SAMPLE_STEP_M`` (5 mm) apart, so an approach or an insertion that leaves the workspace half-way is caught,
and consecutive solutions along it may not turn a joint by more than ``MAX_JOINT_STEP_RAD`` (a
flip of the arm's configuration is no straight line).

A point is reached when the forward kinematics of the clipped solution lies within ``POS_TOL_M``
(0.1 mm) of it and the tool's orientation within ``ANGLE_TOL_RAD`` of pointing down. The solver
does not know the joint limits (its null-space variant proved unreliable: 62 of 200 tool-down
targets reached); each iterate is clipped to them and fed back, up to ``ITERATIONS`` times (200
of 200 reached, 0.5 ms each; ``docs/ROBOT.md``).

An unreachable point is an ``Unreachable`` (exit 1), one line naming the step, the part, the
waypoint, the point (metres, base frame) and the limit: a joint held at one of its limits (named,
with its range), the arm's reach, or a joint flip along a line. Returns a ``KinematicReport``
(the joint solution of every waypoint and of every sample on the way, ``paths``, from which
``rap.robot.arms.trajectory`` times the Panda's trajectory; the worst errors, the solve count and
the seconds). The UR arms have their own check (``rap.robot.arms.ur_check``); the front door
for any arm is ``rap.robot.arms.export.check_arm``.

Cost: about 0.1-0.5 ms a solve; a 22-step plan has about 22 x 90 solves (``benchmarks/
robot_export.py``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from rap.errors import EXIT_INFEASIBLE, RapError
from rap.robot.arm import ARM_MODELS, load_arm, open_world, set_joints, tcp_pose
from rap.robot.program import Program

__all__ = ["Unreachable", "KinematicReport", "check_program", "IkSolver", "POS_TOL_M",
           "ANGLE_TOL_RAD", "MAX_JOINT_STEP_RAD", "ITERATIONS", "SAMPLE_STEP_M", "line_samples"]

POS_TOL_M = 1e-4
ANGLE_TOL_RAD = 2e-3
MAX_JOINT_STEP_RAD = 0.5
ITERATIONS = 30
SAMPLE_STEP_M = 0.005  # the Panda's line samples at most this far apart (its trajectory's knots)
_DOWN = (1.0, 0.0, 0.0, 0.0)  # quaternion xyzw: a half turn about x (URScript rotvec (pi, 0, 0))


class Unreachable(RapError):
    """A waypoint or a point of a linear segment the arm cannot reach (module doc). Exit 1."""

    exit_code = EXIT_INFEASIBLE


@dataclass(frozen=True)
class KinematicReport:
    """What the check found: ``joints[i]`` the solution of waypoint ``i`` (program order),
    ``solves`` the IK problems solved, the worst position (m) and angle (rad) errors, seconds."""

    joints: tuple[tuple[float, ...], ...]
    solves: int
    worst_position_m: float
    worst_angle_rad: float
    seconds: float
    arm: str = "panda"
    branch: str = ""  # the IK branch kept along the program (UR arms)
    #: per waypoint, the joint vectors of the samples of the move into it (its end last)
    paths: tuple[np.ndarray, ...] = ()


def _angle(q1, q2) -> float:
    d = abs(sum(a * b for a, b in zip(q1, q2)))
    return 2.0 * math.acos(min(1.0, d))


class IkSolver:
    """Tool-down IK on one arm in its own DIRECT world (module doc). ``solve(target, seed)``
    puts the TCP, ``tool_offset_m`` below the arm's TCP link along the tool axis, at ``target``;
    returns ``(q, position error, angle error, clipped joint indices)``."""

    def __init__(self, arm: str = "panda", world=None, tool_offset_m: float = 0.0):
        self.model = ARM_MODELS[arm]
        self.lift = np.array([0.0, 0.0, float(tool_offset_m)])  # TCP -> link, tool pointing down
        self.world = world if world is not None else open_world()
        self.arm = load_arm(self.world, self.model)
        self.lower = np.array(self.model.lower)
        self.upper = np.array(self.model.upper)

    def solve(self, target, seed) -> tuple[np.ndarray, float, float, list[int]]:
        w, m = self.world, self.model
        q = np.array(seed, dtype=float)
        set_joints(w, self.arm, m, q)
        target = [float(v) for v in np.asarray(target, dtype=float) + self.lift]
        err, ang, clipped = math.inf, math.inf, []
        for _ in range(ITERATIONS):
            raw = np.array(w.calculateInverseKinematics(self.arm, m.tcp_link, target, _DOWN,
                                                        maxNumIterations=50,
                                                        residualThreshold=1e-7)[:len(m.joints)])
            q = np.clip(raw, self.lower, self.upper)
            clipped = [i for i in range(len(q)) if abs(raw[i] - q[i]) > 1e-6]
            pos, orn = tcp_pose(w, self.arm, m, q)
            err, ang = float(np.linalg.norm(pos - target)), _angle(orn, _DOWN)
            if err < POS_TOL_M and ang < ANGLE_TOL_RAD:
                break
        return q, err, ang, clipped

    def close(self) -> None:
        self.world.disconnect()


def _where(step, wp, point) -> str:
    x, y, z = (float(v) for v in point)
    return (f"step {step.index} ({step.part}), waypoint {wp.name} at ({x:.3f}, {y:.3f}, {z:.3f}) m")


def _fail(solver, step, wp, point, err, ang, clipped) -> Unreachable:
    m = solver.model
    if clipped:
        i = clipped[0]
        limit = (f"{m.joint_names[i]} held at its limit (range [{m.lower[i]:.4f}, "
                 f"{m.upper[i]:.4f}] rad)")
    else:
        limit = f"beyond the {m.name}'s reach ({m.reach_m} m)"
    return Unreachable(f"{_where(step, wp, point)} is unreachable: {limit}; the closest tool-down "
                       f"pose misses it by {err * 1000:.1f} mm and {math.degrees(ang):.1f} deg")


def line_samples(a, b, n_min: int, max_step_m: float) -> list[np.ndarray]:
    """Points of the segment from ``a`` to ``b`` (``a`` left out, ``b`` last): at least
    ``n_min - 1`` of them, at most ``max_step_m`` apart."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(int(n_min), int(math.ceil(float(np.linalg.norm(b - a)) / max_step_m)) + 1)
    return [a + (b - a) * t for t in np.linspace(0, 1, n)[1:]]


def check_program(program: Program, solver: IkSolver | None = None) -> KinematicReport:
    """Check every waypoint and linear segment of ``program`` on the Panda (module doc). Raises
    ``Unreachable`` (exit 1) at the first point the arm cannot reach."""
    t0 = time.perf_counter()
    own = solver is None
    solver = solver or IkSolver(program.cell.robot.arm,
                                tool_offset_m=program.cell.gripper.tool_offset_m)
    try:
        n = program.cell.motion.samples_per_segment
        q = np.array(solver.model.home)
        prev = None
        joints, paths, solves, worst_p, worst_a = [], [], 0, 0.0, 0.0
        for step in program.steps:
            for wp in step.waypoints:
                end = np.array(wp.position)
                line = wp.motion == "movel" and prev is not None
                points = line_samples(prev, end, n, SAMPLE_STEP_M) if line else [end]
                path = []
                for pt in points:
                    q_new, err, ang, clipped = solver.solve(pt, q)
                    solves += 1
                    if err >= POS_TOL_M or ang >= ANGLE_TOL_RAD:
                        raise _fail(solver, step, wp, pt, err, ang, clipped)
                    if line:
                        jump = np.abs(q_new - q)
                        if jump.max() > MAX_JOINT_STEP_RAD:
                            i = int(jump.argmax())
                            raise Unreachable(
                                f"{_where(step, wp, pt)}: the arm cannot follow the line: "
                                f"{solver.model.joint_names[i]} turns {jump[i]:.2f} rad between "
                                f"samples (limit {MAX_JOINT_STEP_RAD} rad)")
                    worst_p, worst_a = max(worst_p, err), max(worst_a, ang)
                    q = q_new
                    path.append(q)
                joints.append(tuple(float(v) for v in q))
                paths.append(np.array(path))
                prev = end
        return KinematicReport(tuple(joints), solves, worst_p, worst_a,
                               time.perf_counter() - t0, arm=solver.model.name,
                               paths=tuple(paths))
    finally:
        if own:
            solver.close()
