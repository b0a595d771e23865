"""A step's clearance: how far its moving parts can move across the insertion at the goal before
they touch a fixed part anew (exact).

``clearance(assembly, operation)`` is the smaller of the two free travels at the goal along the
insertion's normal, ``+n`` and ``-n``: the position error across the insertion that the step's
geometry leaves room for on either side. 0 for a tight fit (the moving parts are blocked across at
once); None when nothing lies across in either direction within the assembly's extent.

Exact: coordinates are scaled to integers (``rap.geometry.exact``), parts are split into convex
pieces (``rap.geometry.validation.part_pieces``), and for each moving piece ``a`` and fixed piece
``b`` the free travel along an integer direction ``u`` is where the ray ``t u`` first enters the
interior of the Minkowski difference ``b - a`` (a convex polygon: the hull of the vertex
differences). For a convex set with the origin on its boundary the ray enters the interior at once
or never, so touching pieces that slide past each other do not count, and pieces blocked at once
give 0. The travel is a ``Fraction`` of ``u``; only the final length in assembly units is a float
(``|u|``). Cost: O(pa x pb x (va x vb) log(va x vb)) for the piece pairs whose boxes can meet
within the assembly's extent.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence

from rap.assembly import Assembly
from rap.geometry.exact import IVec, exact_direction, to_integers
from rap.geometry.validation import part_pieces
from rap.operation import Operation

__all__ = ["clearance", "free_travel"]


def _hull(points: Sequence[IVec]) -> list[IVec]:
    """Convex hull, CCW, no collinear points (Andrew's monotone chain, integer crosses)."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[IVec] = []
    for p in pts:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[IVec] = []
    for p in reversed(pts):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def _entry(hull: Sequence[IVec], u: IVec) -> Fraction | None:
    """Where the ray ``t u`` (t >= 0) enters the interior of the convex polygon ``hull`` (CCW), as
    ``t``; None when it never does."""
    if len(hull) < 3:
        return None  # no interior
    lo, hi = Fraction(0), None
    for i, p in enumerate(hull):
        q = hull[(i + 1) % len(hull)]
        ex, ey = q[0] - p[0], q[1] - p[1]
        a = ex * u[1] - ey * u[0]  # inside: t a > b
        b = ex * p[1] - ey * p[0]
        if a > 0:
            lo = max(lo, Fraction(b, a))
        elif a < 0:
            t = Fraction(b, a)
            hi = t if hi is None or t < hi else hi
        elif b >= 0:
            return None  # parallel to an edge, on or outside it
    if hi is not None and hi <= lo:
        return None
    return lo


def _box(piece):
    xs, ys = [p[0] for p in piece], [p[1] for p in piece]
    return min(xs), min(ys), max(xs), max(ys)


def free_travel(moving: Sequence[Sequence[IVec]], fixed: Sequence[Sequence[IVec]], u: IVec,
                reach: int) -> Fraction | None:
    """How far (in multiples of ``u``) the convex pieces ``moving`` travel along ``u`` before
    entering a piece of ``fixed``; None when none within ``reach`` (in coordinate units, a bound
    used to skip far piece pairs)."""
    best: Fraction | None = None
    for a in moving:
        ax0, ay0, ax1, ay1 = _box(a)
        for b in fixed:
            bx0, by0, bx1, by1 = _box(b)
            if bx0 > ax1 + reach or bx1 < ax0 - reach or by0 > ay1 + reach or by1 < ay0 - reach:
                continue
            t = _entry(_hull([(bx - ax, by - ay) for bx, by in b for ax, ay in a]), u)
            if t is not None and (best is None or t < best):
                best = t
    return best


def clearance(assembly: Assembly, operation: Operation) -> float | None:
    """The step's clearance in assembly units (module doc)."""
    ia = to_integers(assembly)
    pieces = dict(zip((p.id for p in ia.parts), part_pieces(ia)))
    moving = [pc for i in sorted(operation.moving) for pc in pieces[i]]
    fixed = [pc for i in sorted(operation.fixed) for pc in pieces[i]]
    d = exact_direction(operation.exact_direction or operation.direction)
    xs = [x for pc in moving + fixed for x, _ in pc]
    ys = [y for pc in moving + fixed for _, y in pc]
    reach = max(max(xs) - min(xs), max(ys) - min(ys))
    travels = []
    for u in ((-d[1], d[0]), (d[1], -d[0])):
        t = free_travel(moving, fixed, u, reach)
        if t is not None:
            travels.append(float(t) * math.hypot(*u))
    if not travels:
        return None
    return min(travels) / ia.scale
