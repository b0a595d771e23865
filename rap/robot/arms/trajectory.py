"""The Panda's program as a time-parametrized joint trajectory within its jerk-limited dynamics.

``plan_trajectory(program, report)`` takes the joint vectors of the Panda's kinematic check
(``rap.robot.kinematics.check_program``: every waypoint and every line sample, at most 5 mm
apart, ``KinematicReport.paths``) and times the program with Ruckig (``ruckig``, jerk-limited
time-optimal profiles), one move at a time, each from rest to rest:

* the path of a move is a curve ``q(s)`` in joint space: a ``movej`` the straight joint line
  ``q0 + s (q1 - q0)``, ``s`` in [0, 1]; a ``movel`` the natural cubic spline through its samples
  over the distance ``s`` travelled by the TCP (m), so the TCP follows the line (the samples are
  on it; between them the spline stays within micrometres of it);
* Ruckig times ``s`` alone (one degree of freedom, rest to rest: ``s`` never turns back) under
  bounds ``v, a, j`` chosen so that every joint stays within the arm's limits whatever the
  profile: with ``D1, D2, D3`` the largest ``|q'|, |q''|, |q'''|`` of a joint along the path,
  ``D1 v <= V``, ``D2 v^2 + D1 a <= A`` and ``D3 v^3 + 3 D2 v a + D1 j <= J``, half of each budget
  (``BUDGET``) for the path's own curvature terms. ``v`` is also the cell's speed (m/s for a line,
  ``joint_speed_rad_s`` for a joint move), ``a`` its acceleration.

The trajectory is split where the vacuum switches (``TrajectorySegment.action`` after its last
point): a ROS 2 ``FollowJointTrajectory`` goal a segment, the gripper between them
(``rap.robot.arms.ros``). It starts at the arm's home pose. ``sample(trajectory, dt_s)`` gives the
positions, velocities, accelerations and jerks at a fixed period; ``limit_ratios`` the largest
``|qd| / V``, ``|qdd| / A``, ``|qddd| / J`` over them (all at most 1 by construction; the tests
check it). Cost: one small linear solve a line and one Ruckig profile a move (about 50 us);
sampling O(duration / dt_s x joints).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rap.robot.arms.registry import ArmSpec, arm_spec
from rap.robot.kinematics import KinematicReport
from rap.robot.program import Program

__all__ = ["PathMove", "TrajectorySegment", "JointTrajectory", "plan_trajectory", "sample",
           "limit_ratios", "BUDGET", "LINEAR_JERK_M_S3"]

BUDGET = 0.5  # the share of each joint limit left to the path parameter's own v, a, j
LINEAR_JERK_M_S3 = 5.0  # the TCP's jerk along a line (m/s^3); a joint move's is the arm's


class _Spline:
    """A natural cubic spline through knots ``y`` (n+1, dof) at uniform ``u`` from 0 to
    ``length``; a straight line for two knots."""

    def __init__(self, y: np.ndarray, length: float):
        self.y, self.n = np.asarray(y, dtype=float), len(y) - 1
        self.h = length / self.n
        M = np.zeros_like(self.y)
        if self.n > 1:
            k = self.n - 1
            A = 4 * np.eye(k) + np.eye(k, k=1) + np.eye(k, k=-1)
            rhs = 6 * (self.y[2:] - 2 * self.y[1:-1] + self.y[:-2]) / self.h ** 2
            M[1:-1] = np.linalg.solve(A, rhs)
        self.M = M

    def eval(self, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """q, q', q'', q''' at the distances ``u`` (shape (m,)): each (m, dof)."""
        u = np.clip(np.asarray(u, dtype=float), 0.0, self.n * self.h)
        i = np.minimum((u / self.h).astype(int), self.n - 1)
        t = (u - i * self.h)[:, None]
        y0, y1, M0, M1, h = self.y[i], self.y[i + 1], self.M[i], self.M[i + 1], self.h
        b = (y1 - y0) / h - h * (2 * M0 + M1) / 6
        d3 = (M1 - M0) / h
        return (y0 + b * t + M0 / 2 * t ** 2 + d3 / 6 * t ** 3, b + M0 * t + d3 / 2 * t ** 2,
                M0 + d3 * t, np.broadcast_to(d3, t.shape[:1] + d3.shape[1:]))


@dataclass(frozen=True)
class PathMove:
    """One move, rest to rest: its waypoint (``step``, ``name``), the path ``q(s)`` over
    ``length`` (m for a line, 1 for a joint move), the bounds on ``s`` and Ruckig's profile."""

    step: int
    name: str
    motion: str
    length: float
    spline: _Spline
    v: float
    a: float
    j: float
    profile: object  # ruckig.Trajectory (1 degree of freedom)

    @property
    def duration(self) -> float:
        return float(self.profile.duration)


@dataclass(frozen=True)
class TrajectorySegment:
    """Moves run one after the other, then ``action`` (``grip_on``, ``grip_off`` or "")."""

    moves: tuple[PathMove, ...]
    action: str
    step: int

    @property
    def duration(self) -> float:
        return sum(m.duration for m in self.moves)


@dataclass(frozen=True)
class JointTrajectory:
    """The whole program (module doc): its segments and the arm."""

    arm: str
    joint_names: tuple[str, ...]
    segments: tuple[TrajectorySegment, ...]

    @property
    def duration(self) -> float:
        return sum(s.duration for s in self.segments)


def _bounds(spec: ArmSpec, spline: _Spline, v_cap: float, a_cap: float, j_cap: float):
    """The largest (v, a, j) of ``s`` that keep every joint within its limits (module doc)."""
    m = max(8, 8 * spline.n)
    _, d1, d2, d3 = spline.eval(np.linspace(0, spline.n * spline.h, m + 1))
    D1 = np.abs(d1).max(axis=0) * 1.02 + 1e-12
    D2 = np.abs(d2).max(axis=0) * 1.02
    D3 = np.abs(d3).max(axis=0) * 1.02
    V, A, J = (np.array(x) for x in (spec.max_velocity, spec.max_acceleration, spec.max_jerk))
    v = min(v_cap, float((V / D1).min()))
    v = min(v, float(np.sqrt(BUDGET * A / np.maximum(D2, 1e-12)).min()))
    v = min(v, float(np.cbrt(BUDGET * J / 2 / np.maximum(D3, 1e-12)).min()))
    a = min(a_cap, float(((A - D2 * v * v) / D1).min()))
    a = min(a, float(((BUDGET * J / 2) / np.maximum(3 * D2 * v, 1e-12)).min()))
    j = min(j_cap, float(((J - D3 * v ** 3 - 3 * D2 * v * a) / D1).min()))
    return v, a, j


def _profile(length: float, v: float, a: float, j: float):
    from ruckig import InputParameter, Result, Ruckig, Trajectory

    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [float(length)]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v], [a], [j]
    traj = Trajectory(1)
    result = Ruckig(1).calculate(inp, traj)
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"ruckig: {result}")  # not for valid bounds: a bug
    return traj


def plan_trajectory(program: Program, report: KinematicReport) -> JointTrajectory:
    """The Panda's trajectory of ``program`` from its check's ``report`` (module doc)."""
    spec = arm_spec(program.cell.robot.arm)
    mo = program.cell.motion
    q_prev = np.array(spec.home, dtype=float)
    segments, moves = [], []
    for wp, path in zip(program.waypoints, report.paths):
        knots = np.vstack([q_prev, path])
        length = (float(np.linalg.norm(np.subtract(wp.position, prev_pos)))
                  if wp.motion == "movel" and len(path) > 1 else 0.0)
        if length > 1e-6:  # a line; one of no length is timed as a joint move
            spline = _Spline(knots, length)
            caps = (wp.speed, mo.linear_acceleration_m_s2, LINEAR_JERK_M_S3)
        else:
            length, spline = 1.0, _Spline(knots[[0, -1]], 1.0)
            turn = max(float(np.abs(knots[-1] - knots[0]).max()), 1e-9)  # the leading joint's
            caps = (mo.joint_speed_rad_s / turn, mo.joint_acceleration_rad_s2 / turn,
                    BUDGET * min(spec.max_jerk) / turn)
        if float(np.abs(knots[-1] - knots[0]).max()) > 0:
            v, a, j = _bounds(spec, spline, *caps)
            moves.append(PathMove(wp.step, wp.name, wp.motion, length, spline, v, a, j,
                                  _profile(length, v, a, j)))
        if wp.action:
            segments.append(TrajectorySegment(tuple(moves), wp.action, wp.step))
            moves = []
        q_prev, prev_pos = knots[-1], wp.position
    if moves:
        segments.append(TrajectorySegment(tuple(moves), "", moves[-1].step))
    return JointTrajectory(spec.name, spec.joint_names, tuple(segments))


def _move_samples(move: PathMove, t: np.ndarray, jerk: bool):
    """q, qd, qdd, qddd (zeros unless ``jerk``) of ``move`` at its times ``t``."""
    h = 1e-6
    s, sd, sdd, sddd = (np.zeros(len(t)) for _ in range(4))
    for k, tk in enumerate(t):
        p, v, a = move.profile.at_time(float(tk))
        s[k], sd[k], sdd[k] = p[0], v[0], a[0]
        if not jerk:
            continue
        lo = move.profile.at_time(max(0.0, float(tk) - h))[2][0]
        hi = move.profile.at_time(min(move.duration, float(tk) + h))[2][0]
        span = min(move.duration, tk + h) - max(0.0, tk - h)
        sddd[k] = (hi - lo) / span if span > 0 else 0.0
    q, d1, d2, d3 = move.spline.eval(s)
    sd, sdd, sddd = sd[:, None], sdd[:, None], sddd[:, None]
    return (q, d1 * sd, d2 * sd ** 2 + d1 * sdd,
            d3 * sd ** 3 + 3 * d2 * sd * sdd + d1 * sddd)


def sample(segment: TrajectorySegment, dt_s: float, jerk: bool = True):
    """``(t, q, qd, qdd, qddd)`` of a segment every ``dt_s`` seconds of each move (its end
    included): arrays (m,) and (m, dof); ``jerk=False`` leaves ``qddd`` zero (cheaper)."""
    ts, parts, t0 = [], [], 0.0
    for move in segment.moves:
        n = max(1, int(np.ceil(move.duration / dt_s)))
        t = np.linspace(0.0, move.duration, n + 1)
        if parts:
            t = t[1:]  # the previous move's end (at rest) is this one's start
        ts.append(t0 + t)
        parts.append(_move_samples(move, t, jerk))
        t0 += move.duration
    if not parts:
        return np.zeros(0), *(np.zeros((0, 0)) for _ in range(4))
    return (np.concatenate(ts), *(np.vstack([p[i] for p in parts]) for i in range(4)))


def limit_ratios(trajectory: JointTrajectory, dt_s: float = 0.002) -> tuple[float, float, float]:
    """The largest ``|qd| / V``, ``|qdd| / A`` and ``|qddd| / J`` over every sample every
    ``dt_s`` seconds, and whether every position is within the joint limits (module doc)."""
    spec = arm_spec(trajectory.arm)
    V, A, J = (np.array(x) for x in (spec.max_velocity, spec.max_acceleration, spec.max_jerk))
    worst = np.zeros(3)
    for seg in trajectory.segments:
        _, q, qd, qdd, qddd = sample(seg, dt_s)
        if len(q) == 0:
            continue
        if (q < np.array(spec.lower) - 1e-9).any() or (q > np.array(spec.upper) + 1e-9).any():
            worst[:] = np.inf
        worst = np.maximum(worst, [np.abs(qd / V).max(), np.abs(qdd / A).max(),
                                   np.abs(qddd / J).max()])
    return tuple(float(w) for w in worst)
