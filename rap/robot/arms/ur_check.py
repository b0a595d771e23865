"""The kinematic check on a Universal Robots arm: one IK branch for the whole program.

``check_ur(program)`` puts the TCP (the cup, ``gripper.tool_offset_m`` along the flange's z) on
every waypoint of ``program`` with the tool pointing down, and on every point of every ``movel``
segment (approach, insertion, pick, lift, retreat) at most ``SAMPLE_STEP_M`` (1 mm) apart, and
solves each with the arm's analytic IK (``rap.robot.arms.ur``). It then keeps **one branch**
(shoulder, elbow, wrist) for the whole program: the first of ``ur.BRANCHES`` (shoulder front,
elbow up first) on which every point

* has a solution (else: out of the arm's reach, or not on this branch),
* within the joint limits, each joint taking the turn (``q + 2 pi k``) nearest the previous
  point's, so a joint never winds past its limit unseen,
* at least ``WRIST_MARGIN`` from the wrist singularity (``|sin q5|``), ``ELBOW_MARGIN`` from the
  elbow's (``|sin q3|``: stretched or folded) and ``SHOULDER_MARGIN_M`` from the shoulder's (the
  wrist centre off the cylinder of radius ``d4`` about the base axis),
* and, along a line, no joint turning more than ``MAX_JOINT_STEP_RAD`` between samples.

The program's ``movej`` targets are those joint vectors (``rap.robot.arms.urscript``), so the
controller never chooses a branch. When no branch passes, ``Unreachable`` (exit 1): one line
naming the step, the part, the waypoint, the point and the limit met on the branch that went
furthest. Returns a ``KinematicReport`` (``rap.robot.kinematics``) with the branch's name, the
joint vector of every waypoint and of every sample on the way (``paths``), the worst position
(m) and orientation (rad) error of the solutions' forward kinematics, and the seconds.

Cost: one analytic IK a point (about 60 us) and batched numpy for the rest; a 22-step plan at
1 mm is about 10,000 points (``benchmarks/robot_arms.py``).
"""

from __future__ import annotations

import math
import time

import numpy as np

from rap.robot.arms import ur
from rap.robot.arms.registry import arm_spec
from rap.robot.kinematics import KinematicReport, Unreachable, line_samples
from rap.robot.program import Program

__all__ = ["check_ur", "SAMPLE_STEP_M", "WRIST_MARGIN", "ELBOW_MARGIN", "SHOULDER_MARGIN_M",
           "MAX_JOINT_STEP_RAD"]

SAMPLE_STEP_M = 0.001
WRIST_MARGIN = math.sin(math.radians(10.0))  # |sin q5| at least this
ELBOW_MARGIN = math.sin(math.radians(10.0))  # |sin q3| at least this
SHOULDER_MARGIN_M = 0.05  # the wrist centre this far off the shoulder's singular cylinder
MAX_JOINT_STEP_RAD = 0.2  # between two samples of a line (1 mm apart)


def _points(program: Program):
    """Every point to check, in program order: (step, waypoint, index of the waypoint, point,
    on a line)."""
    n = program.cell.motion.samples_per_segment
    out, prev, k = [], None, 0
    for step in program.steps:
        for wp in step.waypoints:
            end = np.array(wp.position, dtype=float)
            line = wp.motion == "movel" and prev is not None
            for pt in (line_samples(prev, end, n, SAMPLE_STEP_M) if line else [end]):
                out.append((step, wp, k, pt, line))
            prev, k = end, k + 1
    return out


def _walk(spec, sols: np.ndarray, lines: np.ndarray) -> tuple[np.ndarray | None, int, str]:
    """The joint path on one branch (``sols``: (N, 6), NaN where none), unwrapped from the home
    pose; or (None, the first failing point, why)."""
    missing = np.isnan(sols[:, 0])
    if missing.any():
        return None, int(missing.argmax()), "branch"
    q = np.unwrap(np.vstack([spec.home, sols]), axis=0)[1:]
    lo, hi = np.array(spec.lower), np.array(spec.upper)
    bad = ((q < lo) | (q > hi)).any(axis=1)
    if bad.any():
        return None, int(bad.argmax()), "limit"
    m = ur.margins(spec.dh, q)
    bad = (m[:, 0] < WRIST_MARGIN) | (m[:, 1] < ELBOW_MARGIN) | (m[:, 2] < SHOULDER_MARGIN_M)
    if bad.any():
        return None, int(bad.argmax()), "singular"
    step = np.abs(np.diff(q, axis=0)).max(axis=1)
    bad = lines[1:] & (step > MAX_JOINT_STEP_RAD)
    if bad.any():
        return None, int(bad.argmax()) + 1, "line"
    return q, len(q), ""


def _why(spec, kind: str, branch, sols_i: np.ndarray, all_i: np.ndarray, q_prev) -> str:
    if kind == "branch":
        if np.isnan(all_i[:, 0]).all():
            return f"beyond the {spec.name}'s reach ({spec.reach_m} m) with the tool down"
        return f"no solution on the branch {branch} (the arm would have to change branch)"
    q = np.unwrap(np.vstack([q_prev, sols_i]), axis=0)[1]
    if kind == "limit":
        j = int(np.argmax(np.maximum(q - np.array(spec.upper), np.array(spec.lower) - q)))
        return (f"{spec.joint_names[j]} at {q[j]:.3f} rad, beyond its limit "
                f"[{spec.lower[j]:.4f}, {spec.upper[j]:.4f}] rad")
    if kind == "singular":
        wrist, elbow, shoulder = ur.margins(spec.dh, q)
        if wrist < WRIST_MARGIN:
            return f"near the wrist singularity (|sin q5| = {wrist:.3f} < {WRIST_MARGIN:.3f})"
        if elbow < ELBOW_MARGIN:
            return (f"near the elbow singularity, arm stretched or folded (|sin q3| = "
                    f"{elbow:.3f} < {ELBOW_MARGIN:.3f})")
        return (f"near the shoulder singularity (the wrist centre {shoulder * 1000:.0f} mm off "
                f"it, margin {SHOULDER_MARGIN_M * 1000:.0f} mm)")
    return (f"the arm cannot follow the line: a joint turns more than {MAX_JOINT_STEP_RAD} rad "
            f"between samples {SAMPLE_STEP_M * 1000:.0f} mm apart")


def check_ur(program: Program) -> KinematicReport:
    """Check ``program`` on its cell's UR arm (module doc). Raises ``Unreachable`` (exit 1)."""
    t0 = time.perf_counter()
    spec = arm_spec(program.cell.robot.arm)
    points = _points(program)
    off = program.cell.gripper.tool_offset_m
    poses = ur.tool_down_pose(np.array([p for _, _, _, p, _ in points]), off)
    sols = ur.solutions(spec, poses)  # (N, 8, 6)
    lines = np.array([line for *_, line in points])
    best = (-1, 0, "", None)
    for b, branch in enumerate(ur.BRANCHES):
        q, reached, kind = _walk(spec, sols[:, b], lines)
        if q is not None:
            break
        if reached > best[0]:
            best = (reached, b, kind, None)
    else:
        i, b, kind, _ = best
        step, wp, _k, pt, _ = points[i]
        q_prev = np.array(spec.home) if i == 0 else np.unwrap(
            np.vstack([spec.home, sols[:i, b]]), axis=0)[-1]
        x, y, z = (float(v) for v in pt)
        raise Unreachable(
            f"step {step.index} ({step.part}), waypoint {wp.name} at ({x:.3f}, {y:.3f}, {z:.3f})"
            f" m is unreachable on the {spec.name}: "
            f"{_why(spec, kind, ur.BRANCHES[b], sols[i:i + 1, b], sols[i], q_prev)}; no IK "
            f"branch reaches every point (furthest: {ur.BRANCHES[b]})")
    T = ur.fk(spec.dh, q)
    target = poses
    pos_err = float(np.linalg.norm(T[:, :3, 3] - target[:, :3, 3], axis=1).max())
    cos = (np.einsum("nij,nij->n", T[:, :3, :3], target[:, :3, :3]) - 1) / 2
    ang_err = float(np.arccos(np.clip(cos, -1.0, 1.0)).max())
    ks = np.array([k for _, _, k, _, _ in points])
    paths = tuple(q[ks == k] for k in range(int(ks.max()) + 1))
    joints = tuple(tuple(float(v) for v in p[-1]) for p in paths)
    return KinematicReport(joints, len(points), pos_err, ang_err, time.perf_counter() - t0,
                           arm=spec.name, branch=str(ur.BRANCHES[b]), paths=paths)
