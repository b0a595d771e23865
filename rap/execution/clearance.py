"""A step's clearance: how far its moving parts can move across the insertion at the goal before
they touch a fixed part anew (exact).

``clearance(assembly, operation)`` is the smaller of the two free travels at the goal along the
insertion's normal, ``+n`` and ``-n``: the position error across the insertion that the step's
geometry leaves room for on either side. 0 for a tight fit (the moving parts are blocked across at
once); None when nothing lies across in either direction within the assembly's extent.

Exact: coordinates are scaled to integers (``rap.geometry.exact``), parts are split into convex
pieces (``rap.geometry.validation``), and for each moving piece ``a`` and fixed piece
``b`` the free travel along an integer direction ``u`` is where the ray ``t u`` first enters the
interior of the Minkowski difference ``b - a`` (a convex polygon: the hull of the vertex
differences). For a convex set with the origin on its boundary the ray enters the interior at once
or never, so touching pieces that slide past each other do not count, and pieces blocked at once
give 0. The travel is a ``Fraction`` of ``u``; only the final length in assembly units is a float
(``|u|``). Cost: O(pa x pb) integer projections, plus O((va x vb) log(va x vb)) for each piece
pair in a moving piece's strip ahead of it, nearest first, until the rest lie beyond the best
travel found. A part's pieces come from ``assembly_pieces`` (computed once an assembly).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence

from rap.assembly import Assembly
from rap.geometry.blocking import convex_hull
from rap.geometry.exact import IVec, exact_direction
from rap.geometry.validation import assembly_pieces
from rap.operation import Operation

__all__ = ["clearance", "free_travel", "pair_travel"]


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


def pair_travel(a: Sequence[IVec], b: Sequence[IVec], u: IVec) -> Fraction | None:
    """How far (in multiples of ``u``) the convex piece ``a`` travels along ``u`` before entering
    the convex piece ``b``; None when it never does. O(va vb log(va vb))."""
    return _entry(convex_hull([(bx - ax, by - ay) for bx, by in b for ax, ay in a]), u)


def _extent(piece: Sequence[IVec], u: IVec) -> tuple[int, int, int, int]:
    """(min, max) of the piece's projections on ``u`` and on its normal ``w = (-u_y, u_x)``."""
    along = [x * u[0] + y * u[1] for x, y in piece]
    across = [y * u[0] - x * u[1] for x, y in piece]
    return min(along), max(along), min(across), max(across)


def free_travel(moving: Sequence[Sequence[IVec]], fixed: Sequence[Sequence[IVec]],
                u: IVec) -> Fraction | None:
    """How far (in multiples of ``u``) the convex pieces ``moving`` travel along ``u`` before
    entering a piece of ``fixed``; None when they never do. Only fixed pieces in a moving piece's
    open strip along ``u`` and ahead of it can be entered; they are tried nearest first, and one
    whose nearest point lies beyond the best travel found ends the scan (integer projections,
    exact)."""
    uu = u[0] * u[0] + u[1] * u[1]
    spans = sorted((_extent(b, u), b) for b in fixed)
    best: Fraction | None = None
    for a in moving:
        a_lo, a_hi, a_w0, a_w1 = _extent(a, u)
        for (b_lo, b_hi, b_w0, b_w1), b in spans:
            if best is not None and (b_lo - a_hi) >= best * uu:
                break  # every later piece starts at least this far ahead
            if b_hi <= a_lo or b_w1 <= a_w0 or a_w1 <= b_w0:
                continue  # behind the moving piece, or outside its strip
            t = pair_travel(a, b, u)
            if t is not None and (best is None or t < best):
                best = t
    return best


def clearance(assembly: Assembly, operation: Operation) -> float | None:
    """The step's clearance in assembly units (module doc)."""
    ia, part_pieces = assembly_pieces(assembly)
    scale, pieces = ia.scale, dict(zip(ia.ids, part_pieces))
    moving = [pc for i in sorted(operation.moving) for pc in pieces[i]]
    fixed = [pc for i in sorted(operation.fixed) for pc in pieces[i]]
    d = exact_direction(operation.exact_direction or operation.direction)
    travels = []
    for u in ((-d[1], d[0]), (d[1], -d[0])):
        t = free_travel(moving, fixed, u)
        if t is not None:
            travels.append(float(t) * math.hypot(*u))
    if not travels:
        return None
    return min(travels) / scale
