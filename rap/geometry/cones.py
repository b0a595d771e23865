"""Cones of allowed directions and their exact intersection with direction ranges.

Directions are integer vectors on the circle (``rap.geometry.exact``); an ``Arc`` is a connected
set of them: the directions from ``start`` CCW to ``end``, each end in or out (``start_closed``,
``end_closed``), a single direction (``start == end``, both closed), the circle minus one
direction (``start == end``, both open) or the whole circle (``full``). Every predicate here is an
integer cross or dot product; floats appear only in ``arc_middle`` (the unit vector for output, as
``rap.geometry.partitions.range_partition`` makes one) and in ranking pieces by width.

* ``cone_arc(axis, half_angle_deg)``: the closed arc of directions within ``half_angle_deg`` of
  ``axis`` (0 <= deg <= 180). Its two edge rays are rational: the axis turned by ``2 atan(t)``
  with ``t = n / D`` (``D = EDGE_DENOMINATOR = 2**32``), so an edge is the integer vector
  ``(D^2 - n^2, 2 n D)`` in the axis's frame. ``n`` is rounded *inward* (the arc lies inside the
  exact cone) by one unit more than ``floor``, so the float error of ``tan`` never rounds it out:
  the edges lie less than 1e-7 degrees inside the exact cone. A half-angle over 90 degrees is
  turned from the opposite axis by ``180 - deg`` with ``n`` rounded outward. Exact cases: 0 is the
  axis alone, 90 the closed half-plane, 180 the whole circle.
* ``partition_arc(partition)``: a ``Partition``'s range as an ``Arc`` (its removal directions).
* ``intersect(arc, others)``: ``arc`` meet the union of ``others``, as maximal arcs in CCW order.
  Cost: O(k^2) predicates for k arcs (every boundary direction and every gap between two is
  tested against each arc).
* ``arc_middle(arc)``: an exact direction strictly inside the arc (its angular middle; the point
  itself for a single direction) and its float unit vector.
* ``choose_direction(arc, cones, prefer)``: the middle of the piece of ``arc`` inside the cones
  that holds one of the ``prefer`` directions (the first such), else the widest piece; None when
  they do not meet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable, Iterable, Sequence

from rap.geometry.exact import (IVec, angle_key, arc_interior_vector, exact_direction,
                                in_open_arc, open_arc_middle, primitive, same_direction, unit)
from rap.geometry.partitions import Partition

__all__ = ["Arc", "FULL", "EDGE_DENOMINATOR", "cone_arc", "partition_arc", "intersect",
           "arc_middle", "arc_width_rad", "choose_direction"]

EDGE_DENOMINATOR = 1 << 32


@dataclass(frozen=True)
class Arc:
    """A connected set of directions (module doc); ``start``/``end`` primitive integer vectors."""

    start: IVec = (1, 0)
    end: IVec = (1, 0)
    start_closed: bool = True
    end_closed: bool = True
    full: bool = False

    @property
    def is_point(self) -> bool:
        return not self.full and self.start == self.end and self.start_closed and self.end_closed

    def contains(self, d: Sequence[int]) -> bool:
        """Is the direction ``d`` in this arc? Exact."""
        if self.full:
            return True
        if self.is_point:
            return same_direction(d, self.start)
        if (self.start_closed and same_direction(d, self.start)) or (
                self.end_closed and same_direction(d, self.end)):
            return True
        return in_open_arc(d, self.start, self.end)

    def boundary(self) -> tuple[IVec, ...]:
        return () if self.full else (self.start, self.end)


FULL = Arc(full=True)


def _edge_parameter(deg: float, inward: bool) -> int:
    """``n`` with ``2 atan(n / D)`` just below (``inward``) or above ``deg`` degrees, 0 <= deg <= 90."""
    t = math.tan(math.radians(deg) / 2.0) * EDGE_DENOMINATOR
    n = math.floor(t) - 1 if inward else math.ceil(t) + 1
    return max(0, min(EDGE_DENOMINATOR, n))


def _turn(axis: IVec, n: int, sign: int) -> IVec:
    """``axis`` turned by ``sign * 2 atan(n / D)`` (exact integers)."""
    D = EDGE_DENOMINATOR
    c, s = D * D - n * n, sign * 2 * n * D
    ax, ay = axis
    return primitive((c * ax - s * ay, s * ax + c * ay))


def cone_arc(axis: Sequence, half_angle_deg: float) -> Arc:
    """The closed arc of directions within ``half_angle_deg`` of ``axis`` (a nonzero vector of
    ints or Fractions), edges rounded inward (module doc). ``ValueError`` for a zero axis or an
    angle outside [0, 180]."""
    fx, fy = Fraction(axis[0]), Fraction(axis[1])
    if fx == 0 and fy == 0:
        raise ValueError("a cone's axis must not be the zero vector")
    deg = float(half_angle_deg)
    if not 0.0 <= deg <= 180.0:
        raise ValueError(f"half angle {deg}: choose 0 <= degrees <= 180")
    a = exact_direction((fx, fy))
    if deg == 180.0:
        return FULL
    if deg == 0.0:
        return Arc(a, a)
    if deg == 90.0:
        return Arc((a[1], -a[0]), (-a[1], a[0]))
    if deg < 90.0:
        n = _edge_parameter(deg, inward=True)
        if n == 0:
            return Arc(a, a)
        return Arc(_turn(a, n, -1), _turn(a, n, +1))
    b = (-a[0], -a[1])  # deg > 90: the complement of the open cone of 180 - deg around -axis
    n = _edge_parameter(180.0 - deg, inward=False)
    return Arc(_turn(b, n, +1), _turn(b, n, -1))


def partition_arc(p: Partition) -> Arc:
    """The removal directions of a ``rap.geometry.partitions.Partition`` as an ``Arc``."""
    if p.span == "circle":
        return FULL
    if p.span == "vertex":
        return Arc(p.range_start, p.range_start)
    return Arc(primitive(p.range_start), primitive(p.range_end), p.start_closed, p.end_closed)


def _pieces(boundaries: Iterable[IVec], member: Callable[[IVec], bool]) -> list[Arc]:
    """The maximal arcs of a set of directions given by ``member`` whose boundary directions are
    among ``boundaries`` (each point and each open gap between consecutive points is wholly in or
    out), in CCW order from angle 0."""
    pts = sorted({primitive(b) for b in boundaries}, key=angle_key)
    if not pts:
        return [FULL] if member((1, 0)) else []
    k = len(pts)
    # cyclic sequence of elements: point i, gap (i, i+1)
    gaps = [member(arc_interior_vector(pts[i], pts[(i + 1) % k])) for i in range(k)]
    points = [member(p) for p in pts]
    if all(gaps) and all(points):
        return [FULL]
    if k == 1 and gaps[0] and not points[0]:
        return [Arc(pts[0], pts[0], False, False)]
    elems = [x for i in range(k) for x in (("p", i, points[i]), ("g", i, gaps[i]))]
    n = len(elems)
    first = next(j for j in range(n) if not elems[j][2])  # an element outside the set
    out: list[Arc] = []
    run: list[tuple] = []
    for t in range(1, n + 1):
        e = elems[(first + t) % n]
        if e[2]:
            run.append(e)
            continue
        if run:
            out.append(_run_arc(run, pts))
            run = []
    return sorted(out, key=lambda a: angle_key(a.start))


def _run_arc(run: list[tuple], pts: list[IVec]) -> Arc:
    k = len(pts)
    kind0, i0, _ = run[0]
    kind1, i1, _ = run[-1]
    if kind0 == "p":
        start, sc = pts[i0], True
    else:
        start, sc = pts[i0], False
    if kind1 == "p":
        end, ec = pts[i1], True
    else:
        end, ec = pts[(i1 + 1) % k], False
    return Arc(start, end, sc, ec)


def intersect(arc: Arc, others: Sequence[Arc]) -> list[Arc]:
    """``arc`` meet the union of ``others``: maximal arcs in CCW order of their starts (empty
    when they do not meet; ``[FULL]`` for the whole circle). Exact."""
    bounds = [b for a in (arc, *others) for b in a.boundary()]
    return _pieces(bounds, lambda d: arc.contains(d) and any(o.contains(d) for o in others))


def arc_width_rad(arc: Arc) -> float:
    """The arc's angular width in radians (floats: for ranking only)."""
    if arc.full:
        return 2 * math.pi
    if arc.is_point:
        return 0.0
    if arc.start == arc.end:
        return 2 * math.pi
    a = math.atan2(*reversed(unit(arc.start)))
    b = math.atan2(*reversed(unit(arc.end)))
    return (b - a) % (2 * math.pi)


def arc_middle(arc: Arc, default: IVec = (0, 1)) -> tuple[IVec, tuple[float, float]]:
    """(exact primitive direction, its float unit vector) strictly inside the arc, at its angular
    middle: the point itself for a single direction, ``default`` for the whole circle, the exact
    bisector when both ends have equal length, else ``arc_middle_unit`` read exactly (an exact
    interior vector where floats fall outside a tiny arc)."""
    if arc.full:
        d = primitive(default)
        return d, unit(d)
    if arc.is_point:
        return arc.start, unit(arc.start)
    return open_arc_middle(arc.start, arc.end)


def choose_direction(arc: Arc, cones: Sequence[Arc], prefer: Sequence[Sequence[int]] = ()
                     ) -> tuple[IVec, tuple[float, float]] | None:
    """(exact direction, unit) in the middle of the piece of ``arc`` inside the union of
    ``cones``: the first piece holding a ``prefer`` direction, else the widest (first on ties);
    None when ``arc`` misses every cone."""
    pieces = intersect(arc, cones)
    if not pieces:
        return None
    pick = next((pc for d in prefer for pc in pieces if pc.contains(d)), None)
    if pick is None:
        pick = max(pieces, key=arc_width_rad)  # max keeps the first of equal widths
    default = primitive(prefer[0]) if prefer else (0, 1)
    return arc_middle(pick, default)
