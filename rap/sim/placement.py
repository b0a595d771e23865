"""Start placement of an assembly operation, shared by the simulator and the image renderer.

The moving subassembly starts translated by ``start_offset = -travel * direction`` from its
assembled pose and travels along ``operation.direction`` (a unit vector) back to offset 0. The
start is completely outside the bounding box of the fixed subassembly in the frame aligned with
the direction of motion (axes ``direction`` and its left normal), and at least
``params.start_gap * extent`` before it along the direction, where ``extent`` is the larger side of
the bounding box of the whole subassembly in that frame. Pure floats; no physics import.

Precondition: the operation's parts exist in the assembly; ``direction`` is a unit vector.
"""

from __future__ import annotations

from dataclasses import dataclass

from rap.assembly import Assembly
from rap.operation import Operation

__all__ = ["Placement", "placement", "start_offset", "frame_axes"]


@dataclass(frozen=True)
class Placement:
    """Where the moving subassembly starts, in assembly units."""

    direction: tuple[float, float]  # unit vector of motion (toward the goal)
    start_offset: tuple[float, float]  # translation of the moving parts at the start
    travel: float  # path length: |start_offset|
    extent: float  # larger side of the subassembly's box in the direction-aligned frame
    moving_extent: float  # larger side of the moving subassembly's box in that frame
    center: tuple[float, float]  # centre of the subassembly's box (assembly coordinates)


def frame_axes(direction: tuple[float, float]) -> tuple[tuple[float, float], tuple[float, float]]:
    """``(d, n)``: the unit direction of motion and its left normal."""
    dx, dy = direction
    return (dx, dy), (-dy, dx)


def _box(points, d, n):
    us = [x * d[0] + y * d[1] for x, y in points]
    ws = [x * n[0] + y * n[1] for x, y in points]
    return min(us), max(us), min(ws), max(ws)


def placement(assembly: Assembly, operation: Operation, start_gap: float) -> Placement:
    """The start placement of ``operation`` with gap ``start_gap`` (fraction of the extent)."""
    d, n = frame_axes(operation.direction)
    mov = [xy for i in sorted(operation.moving) for xy in assembly.part(i).float_outer()]
    fix = [xy for i in sorted(operation.fixed) for xy in assembly.part(i).float_outer()]
    mu0, mu1, mw0, mw1 = _box(mov, d, n)
    fu0, fu1, fw0, fw1 = _box(fix, d, n)
    u0, u1, w0, w1 = min(mu0, fu0), max(mu1, fu1), min(mw0, fw0), max(mw1, fw1)
    extent = max(u1 - u0, w1 - w0)
    gap = start_gap * extent
    # moving's far end (mu1) must end up at least `gap` before the fixed box's near end (fu0)
    travel = max(mu1 - fu0 + gap, gap)
    cu, cw = (u0 + u1) / 2, (w0 + w1) / 2
    center = (cu * d[0] + cw * n[0], cu * d[1] + cw * n[1])
    return Placement(
        direction=(d[0], d[1]),
        start_offset=(-travel * d[0], -travel * d[1]),
        travel=travel,
        extent=extent,
        moving_extent=max(mu1 - mu0, mw1 - mw0),
        center=center,
    )


def start_offset(assembly: Assembly, operation: Operation, params=None) -> tuple[float, float]:
    """Translation of the moving subassembly at the start (assembly units)."""
    from rap.sim.params import DEFAULT_PARAMS  # params.py imports nothing heavy

    p = params if params is not None else DEFAULT_PARAMS
    return placement(assembly, operation, p.start_gap).start_offset
