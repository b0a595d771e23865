"""The Panda's trajectory as ROS 2 ``trajectory_msgs/JointTrajectory`` messages, YAML or JSON.

``trajectory_document(program, trajectory)`` is a plain document::

    {"format": "rap-farm joint trajectory", "arm": "panda", "assembly", "fixture",
     "joint_names": [...], "sample_period_s": DT, "duration_s",
     "segments": [{"step": 1, "then": "grip_on", "output": 0,
                   "trajectory": {"joint_names": [...], "points": [
                       {"positions": [...], "velocities": [...], "accelerations": [...],
                        "time_from_start": {"sec": 0, "nanosec": 0}}, ...]}}, ...]}

Each segment's ``trajectory`` is a ``trajectory_msgs/JointTrajectory`` (starting and ending at
rest, time from the segment's start) to send as a ``control_msgs/action/FollowJointTrajectory``
goal (e.g. to ``franka_ros2``'s joint trajectory controller); ``then`` is the vacuum switch on
``output`` after it (``grip_on``, ``grip_off``, or "" at the end). Points every
``SAMPLE_PERIOD_S`` of each move, its end included (``rap.robot.arms.trajectory.sample``).
``trajectory_yaml`` writes the document as block YAML (numbers as flow lists, each with a
decimal point and no exponent, so YAML 1.1 and 1.2 readers agree); ``trajectory_json`` as JSON. Numbers: positions 6 decimals, velocities
and accelerations 5. Cost: O(duration / period x joints).
"""

from __future__ import annotations

import json
import math

from rap.robot.arms.trajectory import JointTrajectory, sample
from rap.robot.program import Program

__all__ = ["trajectory_document", "trajectory_yaml", "trajectory_json", "SAMPLE_PERIOD_S"]

SAMPLE_PERIOD_S = 0.02


def _r(values, nd) -> list[float]:
    return [round(float(v), nd) + 0.0 for v in values]


def _stamp(t: float) -> dict:
    sec = int(math.floor(t))
    return {"sec": sec, "nanosec": int(round((t - sec) * 1e9)) % 1_000_000_000}


def trajectory_document(program: Program, trajectory: JointTrajectory,
                        dt_s: float = SAMPLE_PERIOD_S) -> dict:
    """The document of the module doc."""
    names = list(trajectory.joint_names)
    segments = []
    for seg in trajectory.segments:
        t, q, qd, qdd, _ = sample(seg, dt_s, jerk=False)
        points = [{"positions": _r(q[i], 6), "velocities": _r(qd[i], 5),
                   "accelerations": _r(qdd[i], 5), "time_from_start": _stamp(t[i])}
                  for i in range(len(t))]
        segments.append({"step": seg.step, "then": seg.action,
                         "output": program.cell.gripper.output,
                         "trajectory": {"joint_names": names, "points": points}})
    return {"format": "rap-farm joint trajectory", "arm": trajectory.arm,
            "assembly": program.assembly, "fixture": program.fixture, "joint_names": names,
            "sample_period_s": dt_s, "duration_s": round(trajectory.duration, 6),
            "segments": segments}


def trajectory_json(program: Program, trajectory: JointTrajectory) -> str:
    return json.dumps(trajectory_document(program, trajectory), separators=(",", ":")) + "\n"


def _num(v: float) -> str:
    """A number with a decimal point and no exponent (YAML 1.1 readers take ``1e-05`` for a
    string); the document's numbers have at most 6 decimals."""
    if isinstance(v, int):
        return str(v)
    text = f"{v:.6f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def _scalar(v) -> str:
    """A flow scalar or list: strings quoted as JSON, numbers by ``_num``."""
    if isinstance(v, list):
        return "[" + ", ".join(_scalar(x) for x in v) + "]"
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return _num(v)
    return json.dumps(v)


def trajectory_yaml(program: Program, trajectory: JointTrajectory) -> str:
    """The document as YAML (module doc)."""
    doc = trajectory_document(program, trajectory)
    out = ["# rap-farm joint trajectory: one trajectory_msgs/JointTrajectory a segment; switch "
           "the vacuum ('then') after each"]
    for key in ("format", "arm", "assembly", "fixture", "joint_names", "sample_period_s",
                "duration_s"):
        out.append(f"{key}: {_scalar(doc[key])}")
    out.append("segments:")
    for seg in doc["segments"]:
        out += [f"  - step: {seg['step']}", f"    then: {_scalar(seg['then'])}",
                f"    output: {seg['output']}", "    trajectory:",
                f"      joint_names: {_scalar(seg['trajectory']['joint_names'])}",
                "      points:"]
        for p in seg["trajectory"]["points"]:
            ts = p["time_from_start"]
            out += [f"        - positions: {_scalar(p['positions'])}",
                    f"          velocities: {_scalar(p['velocities'])}",
                    f"          accelerations: {_scalar(p['accelerations'])}",
                    f"          time_from_start: {{sec: {ts['sec']}, nanosec: {ts['nanosec']}}}"]
    return "\n".join(out) + "\n"
