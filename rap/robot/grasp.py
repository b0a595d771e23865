"""Where the suction cup holds a part, and where each part waits in the tray.

**Grasp** (``grasp_point``): the tool points down, so the cup lies on the part's top face.

* horizontal plane: the top face is the whole polygon (the extrusion's top). The cup's centre is
  the part's area centroid when the cup's disc (``cup_diameter_m``) lies inside the polygon there
  (holes excluded); else the point of a 24 x 24 grid over the part's box that lies deepest inside
  it. Depth: ``thickness_m`` (on the top face).
* vertical plane: the top faces are the polygon's horizontal edges with the part below them (the
  extruded strips facing +z); the cup sits on the middle of the highest one that is at least the
  cup's diameter long (and the extrusion at least that deep). Depth: 0 (the mid-plane).

A part with no place for the cup is a ``GraspError`` (exit 2) naming the part and the cup.

**Tray** (``tray_slots``): a pick location ``(x, y)`` in the base frame per part; given slots
(``[tray] slots``) are kept, the others fill a grid from ``origin_m`` in step order, ``columns``
slots a row along +x (0: about square), rows along +y, pitch the largest footprint plus
``spacing_m``. Each part waits in the tray as it will be placed (horizontal: lying flat; vertical:
standing in its assembled orientation), its grasp point above its slot.

Floats. Cost: O(vertices) a part (O(24^2 vertices) when the centroid does not fit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rap.assembly import Assembly
from rap.errors import InputError
from rap.plan.report.poses import centroid
from rap.robot.cell import Cell
from rap.robot.frames import CellFrame

__all__ = ["Grasp", "GraspError", "grasp_point", "tray_slots", "footprint_m"]

_GRID = 24


class GraspError(InputError):
    """The suction cup has no place on a part. Exit status 2."""


@dataclass(frozen=True)
class Grasp:
    """The cup's centre on ``part`` in assembly coordinates (assembled placement), its depth along
    the frame's extrusion axis (metres), and its height above the part's lowest point (metres)."""

    part: str
    point: tuple[float, float]
    depth_m: float
    height_m: float


def _seg_dist(p, a, b) -> float:
    ax, ay, bx, by = a[0], a[1], b[0], b[1]
    vx, vy = bx - ax, by - ay
    L = vx * vx + vy * vy
    t = 0.0 if L == 0 else max(0.0, min(1.0, ((p[0] - ax) * vx + (p[1] - ay) * vy) / L))
    return math.hypot(p[0] - ax - t * vx, p[1] - ay - t * vy)


def _inside(p, ring) -> bool:
    x, y, inside = p[0], p[1], False
    for (x1, y1), (x2, y2) in zip(ring, ring[1:] + ring[:1]):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def _depth_inside(p, rings) -> float:
    """Distance from ``p`` to the part's boundary when inside the part, else -1."""
    if not _inside(p, rings[0]) or any(_inside(p, h) for h in rings[1:]):
        return -1.0
    return min(_seg_dist(p, a, b) for r in rings for a, b in zip(r, r[1:] + r[:1]))


def grasp_point(assembly: Assembly, part: str, frame: CellFrame, cell: Cell) -> Grasp:
    """The cup's place on ``part`` (module doc). Raises ``GraspError``."""
    pt = assembly.part(part)
    rings = [pt.float_outer(), *pt.float_holes()]
    cup_units = cell.gripper.cup_diameter_m / frame.scale_m
    if frame.plane == "horizontal":
        best = centroid(assembly, [part])
        if _depth_inside(best, rings) < cup_units / 2:
            xs, ys = [x for x, _ in rings[0]], [y for _, y in rings[0]]
            cands = [(x, y) for x in np.linspace(min(xs), max(xs), _GRID)
                     for y in np.linspace(min(ys), max(ys), _GRID)]
            best = max(cands, key=lambda q: _depth_inside(q, rings))
            if _depth_inside(best, rings) < cup_units / 2:
                raise GraspError(f"part {part}: the suction cup (gripper.cup_diameter_m = "
                                 f"{cell.gripper.cup_diameter_m} m) fits nowhere on its top face")
        return Grasp(part, (float(best[0]), float(best[1])), frame.thickness_m, frame.thickness_m)
    # vertical: horizontal edges in the plane with the part below them
    up = _up_axis(frame)
    ring = rings[0]
    area2 = sum(x1 * y2 - x2 * y1 for (x1, y1), (x2, y2) in zip(ring, ring[1:] + ring[:1]))
    heights = [x * up[0] + y * up[1] for x, y in ring]
    low = min(heights)
    tops = []
    nxt = list(zip(ring[1:] + ring[:1], heights[1:] + heights[:1]))
    for (p1, h1), (p2, h2) in zip(zip(ring, heights), nxt):
        if abs(h1 - h2) > 1e-9 * max(1.0, abs(h1)):
            continue
        mid = ((p1[0] + p2[0]) / 2, (p1[1] + p2[1]) / 2)
        length = math.hypot(p2[0] - p1[0], p2[1] - p1[1])
        # the interior lies left of a CCW ring's edge: below the edge when left points down
        lx, ly = -(p2[1] - p1[1]), p2[0] - p1[0]
        if area2 < 0:
            lx, ly = -lx, -ly
        if lx * up[0] + ly * up[1] < 0 and length >= cup_units:
            tops.append((h1, mid))
    if not tops or cell.gripper.cup_diameter_m > frame.thickness_m:
        raise GraspError(f"part {part}: no flat top face takes the suction cup (gripper."
                         f"cup_diameter_m = {cell.gripper.cup_diameter_m} m, assembly.thickness_m "
                         f"= {frame.thickness_m} m)")
    h, mid = max(tops)
    return Grasp(part, (float(mid[0]), float(mid[1])), 0.0, (h - low) * frame.scale_m)


def _up_axis(frame: CellFrame) -> tuple[float, float]:
    # the assembly direction whose image is +z
    return float(frame.ex[2]), float(frame.ey[2])


def footprint_m(assembly: Assembly, part: str, frame: CellFrame) -> float:
    """The larger side of the part's footprint on the table (metres): its box in the plane
    (horizontal), or its side extent and the thickness (vertical)."""
    pts = np.array(assembly.part(part).float_outer())
    if frame.plane == "horizontal":
        ext = pts.max(axis=0) - pts.min(axis=0)
        return float(max(ext) * frame.scale_m * math.sqrt(2))  # any yaw fits
    up = _up_axis(frame)
    side = pts @ np.array([up[1], -up[0]])
    return float(max((side.max() - side.min()) * frame.scale_m, frame.thickness_m))


def tray_slots(parts, assembly: Assembly, frame: CellFrame, cell: Cell
               ) -> dict[str, tuple[float, float]]:
    """Pick locations ``(x, y)`` of ``parts`` (in step order) in the base frame (module doc)."""
    tray = cell.tray
    auto = [p for p in parts if tray.slot_of(p) is None]
    out = {p: tray.slot_of(p) for p in parts if tray.slot_of(p) is not None}
    if auto:
        pitch = max(footprint_m(assembly, p, frame) for p in auto) + tray.spacing_m
        cols = tray.columns or max(1, math.ceil(math.sqrt(len(auto))))
        ox, oy = tray.origin_m
        for k, p in enumerate(auto):
            out[p] = (ox + (k % cols) * pitch, oy + (k // cols) * pitch)
    return out
