"""Blocking arcs of ordered pairs of parts under one-step translation (exact).

Translating part ``a`` alone by ``t d`` for ``t`` in (0, inf) makes its interior meet the interior
of ``b`` exactly for the directions ``d`` in the union, over convex pieces A of a and B of b, of
the open cone generated from the origin by the Minkowski difference K = B (+) (-A) (the convex
hull of the points b_v - a_u). Precondition: interiors of a and b are disjoint, so the origin is
not inside K and each cone is pointed (< 180 degrees, origin outside K or at a vertex of K) or an
open half-plane (origin inside an edge of K).

The cone of one piece pair is found without sorting: the mean r of the points b_v - a_u lies in
the interior of K, hence strictly inside the cone; the cone's boundary rays are the extreme
points on either side of r, found by a linear scan with cross products. The union over piece
pairs is merged exactly into disjoint open arcs (two open arcs sharing only an endpoint stay
separate: that direction is not blocked).

Complexity: O(q_a q_b) for a pair of parts (O(q^2)), plus O(k log k) for merging k piece cones.
Blocking of (a, b) at d equals blocking of (b, a) at -d (``BlockedSet.negated``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from rap.geometry.exact import IVec, angle_key, in_open_arc, primitive

__all__ = ["BlockedSet", "EMPTY", "FULL", "piece_cone", "merge_arcs", "blocking_arcs"]

Arc = tuple[IVec, IVec]


@dataclass(frozen=True)
class BlockedSet:
    """A union of disjoint open arcs ``(start, end)`` (CCW from start), or the full circle.

    ``start == end`` denotes the circle minus that single direction. Arcs are sorted by the
    angle of their start.
    """

    arcs: tuple[Arc, ...] = ()
    full: bool = False

    def contains(self, d: Sequence[int]) -> bool:
        """Is direction d blocked (strictly inside one of the open arcs)?"""
        return self.full or any(in_open_arc(d, s, e) for s, e in self.arcs)

    def negated(self) -> "BlockedSet":
        """The blocked set of the reversed pair: every direction negated."""
        if self.full:
            return self
        arcs = [((-s[0], -s[1]), (-e[0], -e[1])) for s, e in self.arcs]
        return BlockedSet(tuple(sorted(arcs, key=lambda a: angle_key(a[0]))))

    def __bool__(self) -> bool:
        return self.full or bool(self.arcs)


EMPTY = BlockedSet()
FULL = BlockedSet((), True)


def piece_cone(A: Sequence[IVec], B: Sequence[IVec]) -> Arc:
    """The open cone (start, end) of B (+) (-A) for convex pieces with disjoint interiors."""
    pts = [(bx - ax, by - ay) for ax, ay in A for bx, by in B]
    rx = sum(p[0] for p in pts)
    ry = sum(p[1] for p in pts)
    sx = sy = ex = ey = 0
    has_s = has_e = False
    for x, y in pts:
        c = rx * y - ry * x
        if c < 0:
            if not has_s or sx * y - sy * x < 0:
                sx, sy, has_s = x, y, True
        elif c > 0:
            if not has_e or ex * y - ey * x > 0:
                ex, ey, has_e = x, y, True
    if not (has_s and has_e):
        raise ValueError("pieces overlap: the blocking cone is not defined")
    return primitive((sx, sy)), primitive((ex, ey))


def merge_arcs(arcs: Sequence[Arc]) -> BlockedSet:
    """Union of open arcs (each at most 180 degrees) as disjoint open arcs, exactly."""
    if not arcs:
        return EMPTY
    if len(arcs) == 1:
        return BlockedSet((tuple(arcs[0]),))
    items = []
    for s, e in arcs:
        ks, ke = angle_key(s), angle_key(e)
        items.append([(0, ks), (1 if ke <= ks else 0, ke), s, e])
    items.sort(key=lambda it: it[0])
    merged: list[list] = []
    for it in items:
        if merged and it[0] < merged[-1][1]:
            last = merged[-1]
            if it[1] > last[1]:
                last[1], last[3] = it[1], it[3]
        else:
            merged.append(it)
    # the last arc may wrap past angle 0 onto the first ones
    while len(merged) > 1:
        first, last = merged[0], merged[-1]
        if (1, first[0][1]) < last[1]:
            end = (first[1][0] + 1, first[1][1])
            if end > last[1]:
                last[1], last[3] = end, first[3]
            merged.pop(0)
        else:
            break
    if len(merged) == 1:
        only = merged[0]
        start_next_turn = (1, only[0][1])
        if only[1] > start_next_turn:
            return FULL
        if only[1] == start_next_turn:
            return BlockedSet(((only[2], only[2]),))
    out = [(m[2], m[3]) for m in merged]
    out.sort(key=lambda a: angle_key(a[0]))
    return BlockedSet(tuple(out))


def blocking_arcs(pieces_a: Sequence[Sequence[IVec]], pieces_b: Sequence[Sequence[IVec]]) -> BlockedSet:
    """Directions in which translating part a (convex pieces) to infinity collides with part b."""
    cones = [piece_cone(A, B) for A in pieces_a for B in pieces_b]
    if len(cones) > 1:
        cones = list(set(cones))
    return merge_arcs(cones)
