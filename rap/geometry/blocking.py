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

The union is one open arc, the circle less one direction, or the circle: it is the set of
directions of the open connected set int(b) (+) -int(a). ``blocking_arcs`` finds it without every
piece pair (``tree_blocking_arcs`` on ``piece_tree`` hierarchies): parts whose hulls are apart
take the cone of their hulls; others visit piece pairs nearest first, skip subtrees whose hull
cone the union found so far already holds, and stop at the full circle.

Complexity: O(h_a + h_b) for parts with hulls apart (h: hull vertices); otherwise at worst
O(q_a q_b) (every piece pair), plus O(k log k) for merging k piece cones; two interlocking jigsaw
pieces of 400 vertices take milliseconds. Blocking of (a, b) at d equals blocking of (b, a) at
-d (``BlockedSet.negated``).
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import Sequence

from rap.geometry.exact import IVec, angle_key, bounding_box, in_open_arc, primitive

__all__ = ["BlockedSet", "EMPTY", "FULL", "piece_cone", "merge_arcs", "blocking_arcs", "PieceTree",
           "piece_tree", "tree_blocking_arcs", "convex_hull"]

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
    return _cone_of_points([(bx - ax, by - ay) for ax, ay in A for bx, by in B])


def _cone_of_points(pts: Sequence[IVec]) -> Arc:
    """The open cone from the origin over the convex hull of ``pts`` (the origin not inside)."""
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
    return tree_blocking_arcs(piece_tree(pieces_a), piece_tree(pieces_b))


@dataclass(frozen=True, eq=False)
class PieceTree:
    """A bounding hierarchy of a part's convex pieces: each node holds the exact convex hull and
    the box of the pieces below it; a leaf holds one piece (its own hull)."""

    hull: tuple[IVec, ...]
    box: tuple[int, int, int, int]
    size: int
    kids: tuple["PieceTree", ...] = ()


def convex_hull(points: Sequence[IVec]) -> tuple[IVec, ...]:
    """The convex hull's vertices, CCW, collinear points dropped (Andrew's monotone chain, exact).
    O(k log k)."""
    pts = sorted(set(points))
    if len(pts) <= 2:
        return tuple(pts)

    def chain(seq):
        out: list[IVec] = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(reversed(pts))
    return tuple(lower[:-1] + upper[:-1])


def piece_tree(pieces: Sequence[Sequence[IVec]]) -> PieceTree:
    """The hierarchy of a part's convex pieces, split at the median of the pieces' centres along
    the longer side of their box. O(k log^2 k) for k pieces, plus the hulls."""
    if len(pieces) == 1:
        piece = tuple(pieces[0])
        return PieceTree(piece, bounding_box(piece), 1)
    box = bounding_box([p for piece in pieces for p in piece])
    axis = 0 if box[2] - box[0] >= box[3] - box[1] else 1
    order = sorted(pieces, key=lambda pc: sum(p[axis] for p in pc) / len(pc))
    half_ = len(order) // 2
    kids = (piece_tree(order[:half_]), piece_tree(order[half_:]))
    return PieceTree(convex_hull(kids[0].hull + kids[1].hull), box, len(pieces), kids)


def _apart(a: PieceTree, b: PieceTree) -> bool:
    """Do the closed hulls not meet? (A hull edge with the other hull strictly outside it.)"""
    (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = a.box, b.box
    if ax1 < bx0 or bx1 < ax0 or ay1 < by0 or by1 < ay0:
        return True
    for P, Q in ((a.hull, b.hull), (b.hull, a.hull)):
        for k in range(len(P)):
            (px, py), (qx, qy) = P[k - 1], P[k]
            ex, ey = qx - px, qy - py
            if all(ex * (y - py) - ey * (x - px) < 0 for x, y in Q):
                return True
    return False


def _minkowski_difference(A: Sequence[IVec], B: Sequence[IVec]) -> list[IVec]:
    """The vertices (collinear ones kept) of B (+) (-A) for CCW convex polygons: their edges merged
    by angle, exact. O(|A| + |B|)."""
    P = [(-x, -y) for x, y in A]  # -A is A turned by 180 degrees: still CCW

    def from_lowest(R):
        k = min(range(len(R)), key=lambda i: (R[i][1], R[i][0]))
        return R[k:] + R[:k]

    P, Q = from_lowest(list(P)), from_lowest(list(B))
    n, m = len(P), len(Q)
    out: list[IVec] = []
    i = j = 0
    while i < n or j < m:
        p, q = P[i % n], Q[j % m]
        out.append((p[0] + q[0], p[1] + q[1]))
        p1, q1 = P[(i + 1) % n], Q[(j + 1) % m]
        c = (p1[0] - p[0]) * (q1[1] - q[1]) - (p1[1] - p[1]) * (q1[0] - q[0])
        if j >= m or (i < n and c > 0):
            i += 1
        elif i >= n or c < 0:
            j += 1
        else:
            i += 1
            j += 1
    return out


def _hull_cone(A: Sequence[IVec], B: Sequence[IVec]) -> Arc:
    """``piece_cone`` of two convex polygons: over every vertex difference when that is cheap,
    else over the vertices of their Minkowski difference."""
    if len(A) * len(B) <= 64:
        return piece_cone(A, B)
    return _cone_of_points(_minkowski_difference(A, B))


def _covers(union: BlockedSet, arc: Arc) -> bool:
    """Is the open arc (at most 180 degrees) inside the union of disjoint open arcs?"""
    if union.full:
        return True
    s, e = arc
    for S, E in union.arcs:
        if S == E:
            if not in_open_arc(S, s, e):
                return True
        elif ((s == S or in_open_arc(s, S, E)) and (e == E or in_open_arc(e, S, E))
              and not in_open_arc(S, s, e)):
            return True
    return False


def tree_blocking_arcs(a: PieceTree, b: PieceTree) -> BlockedSet:
    """``blocking_arcs`` of two parts given as piece trees, exact, by a bounded search.

    The blocked set of a pair is the set of directions of the open, connected set
    int(b) (+) -int(a) (the origin not in it), hence one open arc, the circle minus one direction,
    or the circle. So when the parts' hulls are apart it is the cone of their hulls. Otherwise
    piece pairs are visited nearest first; a pair of subtrees whose hulls are apart is skipped
    when the cone of their hulls (a superset of their pieces' cones) lies inside the union found
    so far, and the search stops once that union is the circle. The result equals the union of
    every piece pair's cone. Cost: O(h_a + h_b) for parts apart; otherwise at worst the
    O(q_a q_b) of all piece pairs, far less where parts interlock (the union fills the circle)
    or meet along a short stretch."""
    if not a.kids and not b.kids:  # two convex parts
        return BlockedSet((piece_cone(a.hull, b.hull),))
    if _apart(a, b):
        return BlockedSet((_hull_cone(a.hull, b.hull),))
    cones: list[Arc] = []
    union = EMPTY
    heap = [(0, 0, 0, a, b)]
    tick = 1
    while heap:
        _, _, _, na, nb = heapq.heappop(heap)
        if not na.kids and not nb.kids:
            cone = piece_cone(na.hull, nb.hull)
            if not _covers(union, cone):
                cones.append(cone)
                union = merge_arcs(cones)
                if union.full:
                    return FULL
            continue
        if cones and _apart(na, nb) and _covers(union, _hull_cone(na.hull, nb.hull)):
            continue
        if nb.kids and (not na.kids or nb.size > na.size):
            pairs = [(na, kid) for kid in nb.kids]
        else:
            pairs = [(kid, nb) for kid in na.kids]
        for ka, kb in pairs:
            heapq.heappush(heap, (_box_gap(ka.box, kb.box), ka.size + kb.size, tick, ka, kb))
            tick += 1
    return union


def _box_gap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> int:
    """The squared distance between two boxes (0 when they meet)."""
    dx = max(0, a[0] - b[2], b[0] - a[2])
    dy = max(0, a[1] - b[3], b[1] - a[3])
    return dx * dx + dy * dy
