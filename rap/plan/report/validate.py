"""An independent check of assembly plans: order, coverage and swept-area collision freedom.

This checker shares no code with the NDBG or the planners: it reads the parts' float coordinates
with shapely and tests each step geometrically.

A step translates ``moving`` along the unit vector ``d`` to its place. It is collision-free when the
region swept by ``moving`` on the way in, from far away (``-L d``, ``L`` several times the size of
the subassembly) to its place, does not overlap the interior of ``fixed``. The swept region of a
closed polygon ``P`` (holes allowed) along the segment ``[0, v]`` is exactly
``P  U  (P + v)  U  parallelogram(e, v) for every boundary edge e of P`` (a point swept over is
either in ``P``, in ``P + v`` or crosses the boundary of ``P`` on the way). Sliding and touching
contacts give overlaps of zero area; an overlap counts only above ``rel_tol`` times the squared
size of the subassembly (floating-point slivers of exact contacts are far below that).

``check_plan(assembly, steps)`` returns a list of problems (empty: valid): n-1 steps, a valid
assembly order (each step's moving and fixed sets are single parts or were assembled earlier; the
last step builds everything), unit directions, and no collision in any step.

No ray, no torch, no rap.geometry.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import shapely
from shapely.geometry import Polygon

from rap.assembly import Assembly
from rap.plan.report.result import is_assembly_order

__all__ = ["part_polygon", "swept_region", "step_overlap", "check_step", "check_plan"]

REL_TOL = 1e-9


def part_polygon(assembly: Assembly, pid: str, dx: float = 0.0, dy: float = 0.0) -> Polygon:
    p = assembly.part(pid)
    shell = [(float(x) + dx, float(y) + dy) for x, y in p.outer]
    holes = [[(float(x) + dx, float(y) + dy) for x, y in h] for h in p.holes]
    return Polygon(shell, holes)


def _rings(assembly: Assembly, pid: str):
    p = assembly.part(pid)
    for ring in p.rings():
        yield [(float(x), float(y)) for x, y in ring]


def swept_region(assembly: Assembly, ids: Iterable[str], vx: float, vy: float):
    """The region covered by the parts ``ids`` translated by ``t (vx, vy)``, ``t`` in [0, 1]."""
    pieces = []
    for pid in ids:
        pieces.append(part_polygon(assembly, pid))
        pieces.append(part_polygon(assembly, pid, vx, vy))
        for ring in _rings(assembly, pid):
            n = len(ring)
            for i in range(n):
                (ax, ay), (bx, by) = ring[i], ring[(i + 1) % n]
                quad = Polygon([(ax, ay), (bx, by), (bx + vx, by + vy), (ax + vx, ay + vy)])
                if quad.area > 0:
                    pieces.append(quad if quad.is_valid else shapely.make_valid(quad))
    return shapely.union_all(pieces)


def step_overlap(assembly: Assembly, moving: Iterable[str], fixed: Iterable[str],
                 direction: tuple[float, float], reach: float = 4.0) -> tuple[float, float]:
    """(overlap area of the swept moving set with the fixed set, size^2 of the subassembly)."""
    moving, fixed = list(moving), list(fixed)
    x0, y0, x1, y1 = assembly.subset_bounds(moving + fixed)
    size = max(x1 - x0, y1 - y0, 1e-12)
    length = reach * math.hypot(x1 - x0, y1 - y0)
    dx, dy = direction
    sweep = swept_region(assembly, moving, -dx * length, -dy * length)  # from far away to place
    fixed_union = shapely.union_all([part_polygon(assembly, p) for p in fixed])
    return float(sweep.intersection(fixed_union).area), size * size


def check_step(assembly: Assembly, moving, fixed, direction, rel_tol: float = REL_TOL) -> str | None:
    """None when the step is a collision-free one-step translation, else the problem as text."""
    dx, dy = float(direction[0]), float(direction[1])
    if not (math.isfinite(dx) and math.isfinite(dy)) or abs(math.hypot(dx, dy) - 1.0) > 1e-9:
        return f"direction ({dx}, {dy}) is not a unit vector"
    area, scale = step_overlap(assembly, moving, fixed, (dx, dy))
    if area > rel_tol * scale:
        return (f"moving {{{','.join(sorted(moving))}}} sweeps through fixed "
                f"{{{','.join(sorted(fixed))}}} along ({dx:+.4f}, {dy:+.4f}): overlap area {area:.4g}")
    return None


def check_plan(assembly: Assembly, steps: Sequence, rel_tol: float = REL_TOL) -> list[str]:
    """Every problem of a plan (objects with ``moving``, ``fixed``, ``direction``); [] if valid."""
    problems = []
    ids = set(assembly.ids)
    for i, s in enumerate(steps, 1):
        unknown = (set(s.moving) | set(s.fixed)) - ids
        if unknown:
            problems.append(f"step {i}: unknown part ids {sorted(unknown)}")
    if problems:
        return problems
    order = is_assembly_order(steps, assembly.ids)
    if order:
        problems.append(order)
    for i, s in enumerate(steps, 1):
        err = check_step(assembly, s.moving, s.fixed, s.direction, rel_tol)
        if err:
            problems.append(f"step {i}: {err}")
    return problems
