"""Shared boundaries on the tolerance grid: one node per meeting point, one geometry per edge.

The exact rings of a drawing (``rap.cad.rings.exact_rings``) are built from these pieces, so that
**touching stays touching**: a boundary shared by two parts gets the same vertices on both sides,
by construction.

1. *Nodes* (``merge_nodes``). The ends of every piece of every loop are merged when they lie
   within the tolerance of each other (union-find over a hash grid of the tolerance's size) and
   each group is snapped once, to the grid point nearest its mean. Two pieces that meet in the
   drawing meet at one node, whatever the floats' rounding.
2. *One edge, one geometry* (``EdgeTable``). Each piece, its ends replaced by their nodes, is
   looked up in a table keyed by its two nodes in canonical order (the smaller first): a piece
   with the same nodes whose vertices all lie within twice the tolerance of the other's polyline,
   and the other's of its (two flattenings of one curve are each within the tolerance of it), is
   the same edge. The two sides of a shared arc, line or spline, drawn once per part in either
   direction, are one edge.
3. *T-junctions* (``split_at_nodes`` over a ``NodeIndex``). Each distinct edge is split at every
   node that lies within the tolerance of it (a vertex of another part on this edge, the end of an
   arc that covers only part of it), and the pieces go through the same table. An edge split
   differently on the two sides of a contact (one long line against two short ones, a circle
   against an arc of it) is split at the union of both sides' nodes, and the pieces match.

The price: features smaller than the tolerance are merged (two vertices within it become one; a
vertex within it of an edge is put on the edge), as the tolerance says. Cost: ``merge_nodes``
near-linear in the E piece ends (a hash grid, union-find); a lookup compares a polyline with the
edges of the same two nodes, amortised linear in their points (each point's search starts where
the previous one matched); a split O(p * k) for a polyline of p points and the k nodes near its
box.
"""

from __future__ import annotations

import math
from collections import defaultdict

from rap.cad.drawing import Point, distance
from rap.cad.snap import Grid

__all__ = ["Node", "merge_nodes", "EdgeTable", "NodeIndex", "split_at_nodes", "closest"]

#: a point of the grid, as integer indices (coordinate = index * step)
Node = tuple[int, int]


class _UnionFind:
    def __init__(self, n: int):
        self.parent = list(range(n))

    def find(self, i: int) -> int:
        root = i
        while self.parent[root] != root:
            root = self.parent[root]
        while self.parent[i] != root:
            self.parent[i], i = root, self.parent[i]
        return root

    def union(self, i: int, j: int) -> None:
        a, b = self.find(i), self.find(j)
        if a != b:
            self.parent[max(a, b)] = min(a, b)


def merge_nodes(points: list[Point], tol: float, grid: Grid) -> list[Node]:
    """The node of each point: points within ``tol`` of each other (transitively) become one,
    snapped at their mean."""
    distinct = list(dict.fromkeys(points))
    uf = _UnionFind(len(distinct))
    cells: dict[tuple[int, int], list[int]] = defaultdict(list)
    for i, (x, y) in enumerate(distinct):
        cx, cy = math.floor(x / tol), math.floor(y / tol)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for j in cells.get((cx + dx, cy + dy), ()):
                    if distance(distinct[i], distinct[j]) <= tol:
                        uf.union(i, j)
        cells[(cx, cy)].append(i)
    members: dict[int, list[Point]] = defaultdict(list)
    for i, p in enumerate(distinct):
        members[uf.find(i)].append(p)
    snapped = {}
    for root, pts in members.items():
        mx = sum(p[0] for p in pts) / len(pts)
        my = sum(p[1] for p in pts) / len(pts)
        snapped[root] = (grid.index(mx), grid.index(my))
    of = {p: snapped[uf.find(i)] for i, p in enumerate(distinct)}
    return [of[p] for p in points]


def _midpoint(poly: list[Point]) -> Point:
    """The point at half the polyline's length."""
    if len(poly) == 2:
        (x0, y0), (x1, y1) = poly
        return ((x0 + x1) / 2, (y0 + y1) / 2)
    lengths = [distance(a, b) for a, b in zip(poly, poly[1:])]
    half = sum(lengths) / 2
    for (a, b), d in zip(zip(poly, poly[1:]), lengths):
        if half <= d and d > 0:
            t = half / d
            return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
        half -= d
    return poly[-1]


def _near_polyline(points: list[Point], poly: list[Point], limit: float) -> bool:
    """Is every point within ``limit`` of the polyline? (Points along it in order: each search
    starts at the segment the previous point was near.)"""
    m = len(poly) - 1
    j = 0
    for p in points:
        for k in (*range(j, m), *range(j)):
            if closest(p, poly[k], poly[k + 1])[0] <= limit:
                j = k
                break
        else:
            return False
    return True


class EdgeTable:
    """Distinct edges: the same two nodes (canonical order), each polyline's vertices within
    twice the tolerance of the other (two flattenings of one curve, each within the tolerance of
    it, with their ends moved to the nodes)."""

    def __init__(self, tol: float):
        self.tol = tol
        self.by_ends: dict[tuple[Node, Node], list[int]] = defaultdict(list)
        self.polys: list[list[Point]] = []  # canonical direction
        self.ends: list[tuple[Node, Node]] = []
        self.mids: list[Point] = []

    def lookup(self, a: Node, b: Node, poly: list[Point]) -> tuple[int, bool]:
        """(edge id, reversed) of the polyline from node a to node b (added when new)."""
        rev = b < a
        if rev:
            a, b, poly = b, a, poly[::-1]
        mid = _midpoint(poly)
        limit = 2 * self.tol
        for e in self.by_ends[(a, b)]:
            other = self.polys[e]
            if other == poly or (distance(self.mids[e], mid) <= 2 * limit
                                 and _near_polyline(poly[1:-1], other, limit)
                                 and _near_polyline(other[1:-1], poly, limit)):
                return e, rev
        e = len(self.polys)
        self.by_ends[(a, b)].append(e)
        self.polys.append(poly)
        self.ends.append((a, b))
        self.mids.append(mid)
        return e, rev


def closest(p: Point, a: Point, b: Point) -> tuple[float, float]:
    """(distance from p to segment ab, parameter of the closest point in [0, 1])."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    den = dx * dx + dy * dy
    t = 0.0 if den == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / den))
    return math.hypot(a[0] + t * dx - p[0], a[1] + t * dy - p[1]), t


class NodeIndex:
    """Nodes sorted by x, for the nodes near a box."""

    def __init__(self, nodes: set[Node], grid: Grid):
        import numpy as np

        self.nodes = sorted(nodes)
        step = grid.step_float
        self.xy = np.array([(x * step, y * step) for x, y in self.nodes],
                           dtype=float).reshape(-1, 2)
        self.pos = {n: (float(self.xy[i, 0]), float(self.xy[i, 1]))
                    for i, n in enumerate(self.nodes)}

    def near(self, x0: float, y0: float, x1: float, y1: float) -> list[Node]:
        import numpy as np

        lo = int(np.searchsorted(self.xy[:, 0], x0, "left"))
        hi = int(np.searchsorted(self.xy[:, 0], x1, "right"))
        if hi <= lo:
            return []
        ys = self.xy[lo:hi, 1]
        return [self.nodes[lo + int(i)] for i in np.nonzero((ys >= y0) & (ys <= y1))[0]]


def split_at_nodes(poly: list[Point], a: Node, b: Node, index: NodeIndex, tol: float
           ) -> list[tuple[Node, Node, list[Point]]]:
    """The polyline from a to b cut at every other node within ``tol`` of it, as
    (from, to, polyline) pieces in order."""
    xs = [p[0] for p in poly]
    ys = [p[1] for p in poly]
    cuts = []
    for n in index.near(min(xs) - tol, min(ys) - tol, max(xs) + tol, max(ys) + tol):
        if n == a or n == b:
            continue
        p = index.pos[n]
        best = None
        for k in range(len(poly) - 1):
            d, t = closest(p, poly[k], poly[k + 1])
            if d <= tol and (best is None or d < best[0]):
                best = (d, k, t)
        if best is None:
            continue
        d, k, t = best
        if (k == 0 and t == 0.0) or (k == len(poly) - 2 and t == 1.0):
            continue
        cuts.append((k, t, d, n))
    if not cuts:
        return [(a, b, poly)]
    cuts.sort()
    pieces = []
    start, start_pt, k0 = a, index.pos[a], 0
    for k, t, _, n in cuts:
        if n == start:
            continue
        inner = [q for q in poly[k0 + 1:k + 1] if q != start_pt] if k >= k0 else []
        if t == 0.0 and inner:
            inner = inner[:-1]  # the cut is at poly[k] itself: the node replaces it
        pieces.append((start, n, [start_pt, *inner, index.pos[n]]))
        start, start_pt, k0 = n, index.pos[n], k + (1 if t == 1.0 else 0)
    pieces.append((start, b, [start_pt, *poly[k0 + 1:-1], index.pos[b]]))
    return pieces
