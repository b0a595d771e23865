"""Exact triangulation and convex decomposition of parts (integer coordinates).

Precondition: the rings are simple, the outer ring is counter-clockwise, holes are clockwise and
strictly inside the outer ring and pairwise disjoint (``rap.geometry.validation`` checks this).

``triangulate`` asks shapely (GEOS) for a constrained Delaunay triangulation, maps each float
output vertex back to the exact input vertex it came from and verifies the result exactly: every
triangle is counter-clockwise with nonzero area and the areas sum to the part's area. If any of
that fails it falls back to exact ear clipping (holes joined to the outer ring by bridges),
verified the same way. ``convex_pieces`` keeps a convex part whole and otherwise merges triangles
greedily across diagonals while the union stays convex (Hertel-Mehlhorn: at most 4x the optimum).

Complexity: shapely's CDT is O(q log q); the exact check O(q); the ear-clipping fallback O(q^3)
worst case; the merge O(q) with a dictionary of directed edges.
"""

from __future__ import annotations

from typing import Sequence

import shapely
from shapely.geometry import Polygon

from rap.geometry.exact import IVec, orient

__all__ = ["triangulate", "ear_clip", "convex_pieces", "is_convex_ring", "ring_area2",
           "TriangulationError"]

Tri = tuple[IVec, IVec, IVec]


class TriangulationError(ValueError):
    """Neither shapely nor ear clipping produced an exactly verified triangulation."""


def ring_area2(ring: Sequence[IVec]) -> int:
    """Twice the signed area of a ring (exact, positive for CCW)."""
    s = 0
    n = len(ring)
    for i in range(n):
        x0, y0 = ring[i]
        x1, y1 = ring[(i + 1) % n]
        s += x0 * y1 - x1 * y0
    return s


def is_convex_ring(ring: Sequence[IVec]) -> bool:
    """True when every turn of the CCW ring is a left turn or straight."""
    n = len(ring)
    return all(orient(ring[i - 1], ring[i], ring[(i + 1) % n]) >= 0 for i in range(n))


def _verify(tris: list[Tri], area2: int) -> bool:
    total = 0
    for a, b, c in tris:
        o = orient(a, b, c)
        if o <= 0:
            return False
        total += o
    return total == area2


def _shapely_triangles(outer, holes) -> list[Tri] | None:
    exact: dict[tuple[float, float], IVec] = {}
    for ring in (outer, *holes):
        for v in ring:
            key = (float(v[0]), float(v[1]))
            if exact.setdefault(key, v) != v:
                return None  # two exact vertices share one float: cannot map back
    try:
        poly = Polygon([(float(x), float(y)) for x, y in outer],
                       [[(float(x), float(y)) for x, y in h] for h in holes])
        coll = shapely.constrained_delaunay_triangles(poly)
        coords = shapely.get_coordinates(shapely.get_parts(coll))
    except Exception:  # GEOS failure: fall back
        return None
    if len(coords) % 4:
        return None
    keys = list(exact)
    tris: list[Tri] = []
    for k in range(0, len(coords), 4):
        tri = []
        for x, y in coords[k:k + 3]:
            v = exact.get((float(x), float(y)))
            if v is None:  # nearest exact vertex (only if GEOS moved a coordinate)
                v = exact[min(keys, key=lambda q: (q[0] - x) ** 2 + (q[1] - y) ** 2)]
            tri.append(v)
        a, b, c = tri
        if orient(a, b, c) < 0:
            b, c = c, b
        tris.append((a, b, c))
    return tris


def _seg_hits(p, q, a, b) -> bool:
    """Does segment pq meet segment ab anywhere except at a shared endpoint (a touching end)?"""
    d1, d2 = orient(p, q, a), orient(p, q, b)
    d3, d4 = orient(a, b, p), orient(a, b, q)
    if ((d1 > 0 and d2 < 0) or (d1 < 0 and d2 > 0)) and ((d3 > 0 and d4 < 0) or (d3 < 0 and d4 > 0)):
        return True

    def on(u, v, w):  # w on closed segment uv, given collinear
        return min(u[0], v[0]) <= w[0] <= max(u[0], v[0]) and min(u[1], v[1]) <= w[1] <= max(u[1], v[1])

    ends = {p, q}
    if d1 == 0 and on(p, q, a) and a not in ends:
        return True
    if d2 == 0 and on(p, q, b) and b not in ends:
        return True
    if d3 == 0 and on(a, b, p) and p not in (a, b):
        return True
    if d4 == 0 and on(a, b, q) and q not in (a, b):
        return True
    if d1 == d2 == 0 and {a, b} == ends:
        return True  # the segment is an edge: not a bridge through the interior
    return False


def _inside(pt2, ring) -> bool:
    """Crossing-number test for a point given at twice its coordinates (not on the boundary)."""
    x, y = pt2
    inside = False
    n = len(ring)
    for i in range(n):
        ax, ay = ring[i][0] * 2, ring[i][1] * 2
        bx, by = ring[(i + 1) % n][0] * 2, ring[(i + 1) % n][1] * 2
        if (ay > y) != (by > y):
            t = (bx - ax) * (y - ay) - (x - ax) * (by - ay)
            if (t > 0) == (by > ay):
                inside = not inside
    return inside


def _bridge(outer: list[IVec], holes: list[list[IVec]]) -> list[IVec]:
    """Join the holes to the outer ring by bridges: one weakly simple CCW ring."""
    ring = list(outer)
    pending = sorted((list(h) for h in holes), key=lambda h: max(h), reverse=True)
    while pending:
        hole = pending.pop(0)
        k = hole.index(max(hole))
        h = hole[k]
        hole = hole[k:] + hole[:k]
        edges = [(ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring))]
        for other in (hole, *pending):
            edges += [(other[i], other[(i + 1) % len(other)]) for i in range(len(other))]
        counts: dict[IVec, int] = {}
        for v in ring:
            counts[v] = counts.get(v, 0) + 1
        cands = sorted(set(ring), key=lambda v: ((v[0] - h[0]) ** 2 + (v[1] - h[1]) ** 2, v))
        chosen = None
        for v in cands:
            if counts[v] > 1:
                continue
            if any(_seg_hits(h, v, a, b) for a, b in edges):
                continue
            mid2 = (h[0] + v[0], h[1] + v[1])
            if not _inside(mid2, ring) or any(_inside(mid2, o) for o in pending):
                continue
            chosen = v
            break
        if chosen is None:
            raise TriangulationError("no bridge from a hole to the outer ring")
        j = ring.index(chosen)
        ring = ring[:j + 1] + hole + [h, chosen] + ring[j + 1:]
    return ring


def ear_clip(outer: Sequence[IVec], holes: Sequence[Sequence[IVec]] = ()) -> list[Tri]:
    """Exact ear clipping (O(q^3) worst case); holes are joined to the outer ring by bridges."""
    ring = _bridge(list(outer), [list(h) for h in holes]) if holes else list(outer)
    tris: list[Tri] = []
    guard = 0
    while len(ring) > 3:
        n = len(ring)
        clipped = False
        for i in range(n):
            a, b, c = ring[i - 1], ring[i], ring[(i + 1) % n]
            o = orient(a, b, c)
            if o == 0 and (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]) > 0:
                del ring[i]  # straight vertex: drop it, no area lost
                clipped = True
                break
            if o <= 0:
                continue
            corners = (a, b, c)
            ok = True
            for p in ring:
                if p in corners:
                    continue
                if orient(a, b, p) >= 0 and orient(b, c, p) >= 0 and orient(c, a, p) >= 0:
                    ok = False
                    break
            if ok:
                tris.append((a, b, c))
                del ring[i]
                clipped = True
                break
        guard += 1
        if not clipped or guard > 100000:
            raise TriangulationError("ear clipping found no ear")
    if len(ring) == 3 and orient(*ring) > 0:
        tris.append((ring[0], ring[1], ring[2]))
    return tris


def triangulate(outer: Sequence[IVec], holes: Sequence[Sequence[IVec]] = ()) -> list[Tri]:
    """CCW triangles whose vertices are exactly input vertices, covering the part exactly."""
    outer = tuple(outer)
    holes = tuple(tuple(h) for h in holes)
    area2 = ring_area2(outer) + sum(ring_area2(h) for h in holes)
    tris = _shapely_triangles(outer, holes)
    if tris is not None and _verify(tris, area2):
        return tris
    tris = ear_clip(outer, holes)
    if not _verify(tris, area2):
        raise TriangulationError("exact check of the triangulation failed")
    return tris


def convex_pieces(outer: Sequence[IVec], holes: Sequence[Sequence[IVec]] = ()) -> list[tuple[IVec, ...]]:
    """Convex CCW polygons with disjoint interiors whose union is the part (exact vertices)."""
    outer = tuple(outer)
    if not holes and is_convex_ring(outer):
        return [outer]
    tris = triangulate(outer, holes)
    pieces: dict[int, list[IVec]] = {}
    owner: dict[tuple[IVec, IVec], int] = {}
    for k, t in enumerate(tris):
        pieces[k] = list(t)
        for i in range(3):
            owner[(t[i], t[(i + 1) % 3])] = k
    for t in tris:  # greedy Hertel-Mehlhorn over the diagonals
        for i in range(3):
            u, v = t[i], t[(i + 1) % 3]
            p, q = owner.get((u, v)), owner.get((v, u))
            if p is None or q is None or p == q:
                continue
            P, Q = pieces[p], pieces[q]
            iv = P.index(v)
            P2 = P[iv:] + P[:iv]  # v ... u
            iu = Q.index(u)
            Q2 = Q[iu:] + Q[:iu]  # u ... v
            if P2[-1] != u or Q2[-1] != v:
                continue
            if orient(P2[-2], u, Q2[1]) < 0 or orient(Q2[-2], v, P2[1]) < 0:
                continue
            merged = P2 + Q2[1:-1]
            pieces[p] = merged
            del pieces[q]
            for j in range(len(merged)):
                owner[(merged[j], merged[(j + 1) % len(merged)])] = p
            owner.pop((u, v), None)
            owner.pop((v, u), None)
    return [tuple(pc) for pc in pieces.values()]
