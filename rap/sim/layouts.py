"""Trials that do not start from the exact assembly: parts where earlier steps left them, and a
moving body held off its place.

A whole plan executed step after step (``rap.execution``) leaves each placed part near its goal,
not on it, and a real gripper holds a part a little off where the arm believes it is. A
``TrialLayout`` says both for one trial of ``rap.sim.simulator.build_scene``:

* ``poses``: part id -> ``Pose``, where that part lies (parts not named lie exactly in place); a
  moving part's pose is its place within the moving subassembly, which the body then carries;
* ``grasp``: the moving body's shapes in the controlled body's frame, off by ``(dx, dy)``
  (assembly units, assembly axes) and turned by ``angle_rad`` about the moving parts' centroid.
  The controller drives the *body* (the gripper) along the commanded path; the parts ride off it by
  the grasp. The simulator still decides success on the body; ``part_pose`` gives where the parts
  really ended, which a rollout checks against the goal and carries on.

A ``Pose`` is ``((pivot_x, pivot_y), (offset_x, offset_y), angle_rad)`` in assembly units: a point
``p`` is taken to ``pivot + R(angle) (p - pivot) + offset``. Floats: these are physics, not
geometry. Cost: O(vertices) per posed piece.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

__all__ = ["Pose", "TrialLayout", "posed_points", "compose_poses", "IDENTITY_GRASP"]

Pose = tuple[tuple[float, float], tuple[float, float], float]

IDENTITY_GRASP = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TrialLayout:
    """One trial's start: where the fixed parts lie and how the moving body is held (module doc)."""

    poses: Mapping[str, Pose] = field(default_factory=dict)
    grasp: tuple[float, float, float] = IDENTITY_GRASP  # (dx, dy, angle_rad), assembly units


def posed_points(points: Sequence[tuple[float, float]], pose: Pose) -> list[tuple[float, float]]:
    """``points`` under ``pose`` (module doc)."""
    (px, py), (ox, oy), ang = pose
    if ang == 0.0:
        return [(x + ox, y + oy) for x, y in points]
    c, s = math.cos(ang), math.sin(ang)
    return [(px + c * (x - px) - s * (y - py) + ox, py + s * (x - px) + c * (y - py) + oy)
            for x, y in points]


def compose_poses(first: Pose, then: Pose) -> Pose:
    """The pose ``then`` applied after ``first``, as one pose about ``then``'s pivot (a part moved
    again, with the subassembly it belongs to)."""
    (p1x, p1y), (o1x, o1y), a1 = first
    (p2x, p2y), (o2x, o2y), a2 = then
    (qx, qy), = posed_points([(p2x, p2y)], first)  # image of p2 under the first pose
    c2, s2 = math.cos(a2), math.sin(a2)
    dx, dy = qx - p2x, qy - p2y
    return (p2x, p2y), (c2 * dx - s2 * dy + o2x, s2 * dx + c2 * dy + o2y), a1 + a2
