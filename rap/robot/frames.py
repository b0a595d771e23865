"""From the assembly's plane to the robot's base frame: one rigid placement and scale per cell.

A point ``p = (x, y)`` of the assembly (its units) goes to the base frame (metres) as follows.

* **vertical** plane: the assembly stands up. Its *up* axis ``u = -gravity / |gravity|`` (``(0, 1)``
  without gravity) becomes ``+z``, its *side* axis ``s = (u_y, -u_x)`` (``(1, 0)`` for up
  ``(0, 1)``) the horizontal direction ``h = (cos yaw, sin yaw, 0)``; the parts are extruded along
  the horizontal normal ``n = (-sin yaw, cos yaw, 0)``, centred on the plane (depth
  ``thickness_m``). The **anchor**, the middle of the assembly's bounding box along ``s`` at its
  lowest point along ``u``, sits at ``(position_m, table height)``.
* **horizontal** plane: the assembly lies on the table, ``x, y`` rotated by ``yaw`` about ``z``,
  extruded upward from the table by ``thickness_m``; the anchor, its bounding box's centre, sits
  at ``position_m``.

Scale: ``Cell.unit_metres(assembly.units)`` metres per unit. ``point(p, depth)`` is exact float
arithmetic (no rounding); ``direction(v)`` maps a unit vector of the plane to the base frame.
The tool always points down (``TOOL_DOWN``: a half turn about x, URScript's rotation vector
``(pi, 0, 0)``). Cost: O(vertices) to find the anchor, O(1) a point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rap.assembly import Assembly
from rap.errors import InputError
from rap.robot.cell import Cell

__all__ = ["CellFrame", "cell_frame", "plan_gravity", "TOOL_DOWN_ROTVEC"]

#: URScript rotation vector of a tool pointing straight down (a half turn about the base's x)
TOOL_DOWN_ROTVEC = (math.pi, 0.0, 0.0)


def plan_gravity(plan_doc: dict) -> tuple[float, float] | None:
    """The gravity vector a plan document was made with (its ``constraints.gravity``), or None."""
    g = (plan_doc.get("constraints") or {}).get("gravity")
    if not g:
        return None
    try:
        gx, gy = map(float, g.split(",") if isinstance(g, str) else g)
    except (TypeError, ValueError):
        raise InputError(f"plan: constraints.gravity {g!r}: not a vector DX,DY") from None
    return None if gx == 0 and gy == 0 else (gx, gy)


@dataclass(frozen=True)
class CellFrame:
    """The placement of an assembly's plane in the base frame (module doc)."""

    plane: str  # "vertical" or "horizontal"
    scale_m: float  # metres per assembly unit
    origin: np.ndarray  # [3] base-frame point of the anchor
    ex: np.ndarray  # [3] base-frame image of the assembly's x axis (unit)
    ey: np.ndarray  # [3] base-frame image of the assembly's y axis (unit)
    anchor: tuple[float, float]  # the assembly point at ``origin``
    depth_axis: np.ndarray  # [3] the extrusion axis: n (vertical) or z (horizontal)
    table_z: float
    thickness_m: float

    def point(self, p, depth: float = 0.0) -> np.ndarray:
        """The base-frame point (metres) of the assembly point ``p`` at ``depth`` metres along the
        extrusion axis (vertical: from the mid-plane; horizontal: above the table)."""
        dx, dy = float(p[0]) - self.anchor[0], float(p[1]) - self.anchor[1]
        return self.origin + self.scale_m * (dx * self.ex + dy * self.ey) + depth * self.depth_axis

    def direction(self, v) -> np.ndarray:
        """The base-frame image of a vector of the plane, normalised (a unit vector stays one)."""
        w = float(v[0]) * self.ex + float(v[1]) * self.ey
        n = float(np.linalg.norm(w))
        return w / n if n > 0 else w

    def top_depth(self) -> float:
        """The depth of the parts' top face: the table-facing extrusion's top (horizontal), 0 on
        the mid-plane (vertical: the top face is found in the plane)."""
        return self.thickness_m if self.plane == "horizontal" else 0.0


def cell_frame(cell: Cell, assembly: Assembly, gravity: tuple[float, float] | None) -> CellFrame:
    """The frame of ``assembly`` in ``cell`` for a plan made with ``gravity`` (None: none); the
    plane ``auto`` is vertical exactly when there is gravity."""
    a = cell.assembly
    plane = a.plane if a.plane != "auto" else ("vertical" if gravity else "horizontal")
    scale = cell.unit_metres(assembly.units)
    yaw = math.radians(a.yaw_deg)
    h = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    n = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    pts = np.array([xy for pid in assembly.ids for xy in assembly.part(pid).float_outer()])
    table = cell.table.height_m
    if plane == "vertical":
        gx, gy = gravity if gravity else (0.0, -1.0)
        norm = math.hypot(gx, gy)
        u = np.array([-gx / norm, -gy / norm])
        s = np.array([u[1], -u[0]])
        # assembly x = s_x * side + u_x * up ; so its image is s_x * h + u_x * z
        ex = s[0] * h + u[0] * z
        ey = s[1] * h + u[1] * z
        side, up = pts @ s, pts @ u
        mid_side, low = (side.min() + side.max()) / 2, up.min()
        anchor_xy = mid_side * s + low * u
        origin = np.array([a.position_m[0], a.position_m[1], table])
        depth_axis = n
    else:
        ex = math.cos(yaw) * np.array([1.0, 0, 0]) + math.sin(yaw) * np.array([0, 1.0, 0])
        ey = -math.sin(yaw) * np.array([1.0, 0, 0]) + math.cos(yaw) * np.array([0, 1.0, 0])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        anchor_xy = (lo + hi) / 2
        origin = np.array([a.position_m[0], a.position_m[1], table])
        depth_axis = z
    return CellFrame(plane=plane, scale_m=scale, origin=origin, ex=ex, ey=ey,
                     anchor=(float(anchor_xy[0]), float(anchor_xy[1])), depth_axis=depth_axis,
                     table_z=table, thickness_m=a.thickness_m)
