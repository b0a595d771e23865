"""Closed loops from drawn paths, and exact rings on the tolerance grid with exact contacts.

``join_loops(paths, tol)`` keeps closed paths as loops and joins open ones (loose LINE and ARC
entities, open polylines, open SVG subpaths) into closed loops, layer by layer, with ezdxf's
``edgeminer`` (``Deposit`` + ``find_all_simple_chains``: chains through vertices of degree 2,
ends within ``tol`` connected). A chain that does not close is an open loop (its free end and the
distance to the nearest other free end are named), a vertex where three or more loose ends meet
is a branch; both are a ``Problem``.

``exact_rings(loops, grid)`` turns the loops into rings of integer grid indices (coordinate =
index * step). **Touching stays touching**: a boundary shared by two parts gets the same vertices
on both sides, by construction:

1. *Nodes.* The ends of every piece of every loop are merged when they lie within the tolerance
   of each other (union-find over a hash grid of the tolerance's size) and each group is snapped
   once, to the grid point nearest its mean. Two pieces that meet in the drawing meet at one
   node, whatever the floats' rounding; a joint of a loop whose ends are apart by more than
   rounding (1e-9 of the drawing's extent) and at most the tolerance is a gap closed (counted).
2. *One edge, one geometry.* Each piece, its ends replaced by their nodes, is looked up in a table
   keyed by its two nodes in canonical order (the smaller first): a piece with the same nodes
   whose vertices all lie within twice the tolerance of the other's polyline, and the other's of
   its (two flattenings of one curve are each within the tolerance of it), is the same edge.
   The two sides of a shared arc, line or spline, drawn once per part in either direction, are
   one edge.
3. *T-junctions.* Each distinct edge is split at every node that lies within the tolerance of it
   (a vertex of another part on this edge, the end of an arc that covers only part of it), and
   the pieces go through the same table. An edge split differently on the two sides of a contact
   (one long line against two short ones, a circle against an arc of it) is split at the union of
   both sides' nodes, and the pieces match.
4. *Flattened once.* Each distinct piece's interior points (its flattening, within the chordal
   tolerance) are snapped once, in canonical direction, and every loop that uses the piece takes
   that vertex list, reversed where it runs the other way.

So two parts that share a boundary in the drawing share its vertices exactly, and their contact is
exact (collinear edges, no gap, no overlap). The price: features smaller than the tolerance are
merged (two vertices within it become one; a vertex within it of an edge is put on the edge), as
the tolerance says. Each ring is then checked exactly: at least 3 vertices and a nonzero area
after snapping, and simple (``rap.geometry.validation.ring_is_simple``); a self-intersection is
named by the two entities whose edges meet.

Cost: O(E log E + P * k) for E piece ends and P flattened points, k the nodes near an edge's box
(timings: ``python benchmarks/cad_import.py``, docs/RESULTS.md).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from fractions import Fraction

from rap.assembly import signed_area2
from rap.cad.drawing import DrawnPath, Point, Problem, Source, fmt_length, fmt_point
from rap.cad.snap import Grid
from rap.geometry.validation import ring_is_simple, segments_intersect

__all__ = ["Loop", "ExactRing", "join_loops", "exact_rings"]

Node = tuple[int, int]


@dataclass
class Loop:
    """A closed sequence of pieces (float polylines, consecutive ends within the tolerance)."""

    pieces: list[tuple[list[Point], Source]]
    source: Source  # the entity that names the loop: the first in file order
    layer: str | None


@dataclass
class ExactRing:
    """A simple ring of grid indices; ``sources[i]`` drew the edge from vertex i to i + 1."""

    vertices: list[Node]
    sources: list[Source]
    loop: Loop

    @property
    def area2(self) -> int:
        return int(signed_area2(self.vertices))


def _dist(p: Point, q: Point) -> float:
    return math.hypot(p[0] - q[0], p[1] - q[1])


# ------------------------------------------------------------------------------------ joining


def _loop_of(paths: list[DrawnPath]) -> Loop:
    pieces = [(pc, p.source) for p in paths for pc in p.pieces]
    first = min((p.source for p in paths), key=lambda s: s.order)
    if len(pieces) == 1:  # a closed curve drawn as one piece: two halves, so each has two ends
        pts = pieces[0][0]
        k = _half_index(pts)
        pieces = [(pts[:k + 1], pieces[0][1]), (pts[k:], pieces[0][1])]
    return Loop(pieces, first, first.layer)


def _half_index(pts: list[Point]) -> int:
    """The index of the interior point nearest half the polyline's length (>= 1, <= len - 2)."""
    if len(pts) < 3:
        raise Problem("a closed piece with fewer than 3 points")  # callers never pass one
    total = sum(_dist(a, b) for a, b in zip(pts, pts[1:]))
    run = 0.0
    for i in range(1, len(pts) - 1):
        run += _dist(pts[i - 1], pts[i])
        if run >= total / 2:
            return i
    return len(pts) - 2


def join_loops(paths: list[DrawnPath], tol: float, unit: str) -> list[Loop]:
    """Closed loops from paths: closed ones as they are, open ones joined within their layer.

    Raises ``Problem`` for an open chain (its free end, the gap to the nearest other free end)
    or a branch of loose ends. Loops come sorted by the file order of their first entity.
    """
    from ezdxf import edgeminer as em

    loops: list[Loop] = []
    loose: dict[str | None, list[DrawnPath]] = defaultdict(list)
    for p in paths:
        single = len(p.pieces) == 1 and len(p.pieces[0]) < 3
        if p.closed or (not single and _dist(p.start, p.end) <= tol):
            if single:
                continue  # a closed path of one straight piece has no area
            loops.append(_loop_of([p]))
        else:
            loose[p.source.layer].append(p)
    for layer in sorted(loose, key=lambda k: (k is None, k or "")):
        group = loose[layer]
        edges = [em.make_edge((*p.start, 0.0), (*p.end, 0.0), payload=i)
                 for i, p in enumerate(group)]
        deposit = em.Deposit(edges, gap_tol=tol)
        chains = sorted(em.find_all_simple_chains(deposit),
                        key=lambda c: min(group[e.payload].source.order for e in c))
        free: list[tuple[Point, Source]] = []
        bad = []
        for chain in chains:
            if len(chain) >= 2 and em.is_loop(chain, gap_tol=tol):
                loops.append(_loop_of([group[e.payload].reversed() if e.is_reverse
                                       else group[e.payload] for e in chain]))
                continue
            first, last = chain[0], chain[-1]
            ends = ((first.start, group[first.payload].source),
                    (last.end, group[last.payload].source))
            for v, src in ends:
                if deposit.degree(v) > 2:
                    linked = deposit.edges_linked_to(v, tol)
                    meet = sorted({group[e.payload].source for e in linked},
                                  key=lambda s: s.order)
                    raise Problem(f"{len(meet)} loose ends meet at {fmt_point((v.x, v.y))} ("
                                  + ", ".join(s.describe() for s in meet[:4])
                                  + "): a loop cannot branch; draw each part as a closed "
                                    "polyline or on a layer of its own")
            free.extend(((v.x, v.y), src) for v, src in ends)
            bad.append(len(free) - 2)
        if bad:
            i = bad[0]
            (p, src) = free[i]
            others = [(_dist(p, q), s, q) for j, (q, s) in enumerate(free) if j != i]
            gap, other, q = min(others, key=lambda t: t[0])
            raise Problem(f"{src.describe()}: open loop: the end at {fmt_point(p)} meets nothing "
                          f"within the tolerance {fmt_length(tol)} {unit}; the gap to the nearest "
                          f"free end, {fmt_point(q)} of {other.describe()}, is {fmt_length(gap)} "
                          f"{unit}")
    loops.sort(key=lambda lp: lp.source.order)
    return loops


# ------------------------------------------------------------------------------------ nodes


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


def _nodes(points: list[Point], tol: float, grid: Grid) -> list[Node]:
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
                    if _dist(distinct[i], distinct[j]) <= tol:
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


# ------------------------------------------------------------------------------------ edges


def _midpoint(poly: list[Point]) -> Point:
    """The point at half the polyline's length."""
    if len(poly) == 2:
        (x0, y0), (x1, y1) = poly
        return ((x0 + x1) / 2, (y0 + y1) / 2)
    lengths = [_dist(a, b) for a, b in zip(poly, poly[1:])]
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
            if _closest(p, poly[k], poly[k + 1])[0] <= limit:
                j = k
                break
        else:
            return False
    return True


class _EdgeTable:
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
            if other == poly or (_dist(self.mids[e], mid) <= 2 * limit
                                 and _near_polyline(poly[1:-1], other, limit)
                                 and _near_polyline(other[1:-1], poly, limit)):
                return e, rev
        e = len(self.polys)
        self.by_ends[(a, b)].append(e)
        self.polys.append(poly)
        self.ends.append((a, b))
        self.mids.append(mid)
        return e, rev


def _closest(p: Point, a: Point, b: Point) -> tuple[float, float]:
    """(distance from p to segment ab, parameter of the closest point in [0, 1])."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    den = dx * dx + dy * dy
    t = 0.0 if den == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / den))
    return math.hypot(a[0] + t * dx - p[0], a[1] + t * dy - p[1]), t


class _NodeIndex:
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


def _split(poly: list[Point], a: Node, b: Node, index: _NodeIndex, tol: float
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
            d, t = _closest(p, poly[k], poly[k + 1])
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


# ------------------------------------------------------------------------------------ rings


def exact_rings(loops: list[Loop], grid: Grid, unit: str) -> tuple[list[ExactRing], int]:
    """The loops as simple exact rings on the grid, and the number of gaps closed (joints of a
    loop whose two ends differ by more than floating-point rounding, at most the tolerance).
    See the module doc."""
    tol = grid.step_float
    ends: list[Point] = []
    for loop in loops:
        for pts, src in loop.pieces:
            for p in (pts[0], pts[-1]):
                try:
                    grid.index(p[0]), grid.index(p[1])
                except ValueError:
                    raise Problem(f"{src.describe()}: coordinate {fmt_point(p)} is past the "
                                  f"bounds of assembly files (|x| <= 10^9)") from None
            ends += (pts[0], pts[-1])
    node_of = _nodes(ends, tol, grid)
    # ends computed from curves (an ARC's from its centre and angles) miss the LINE they join by
    # rounding only: a joint counts as a gap closed past 1e-9 of the drawing's extent
    noise = 1e-9 * max([1.0] + [max(abs(p[0]), abs(p[1])) for p in ends])

    gaps = 0
    k = 0
    loop_ends: list[list[tuple[Node, Node]]] = []
    for loop in loops:
        pairs = []
        for _ in loop.pieces:
            pairs.append((node_of[k], node_of[k + 1]))
            k += 2
        for j, (pts, src) in enumerate(loop.pieces):
            nxt_pts, nxt_src = loop.pieces[(j + 1) % len(loop.pieces)]
            if pairs[j][1] != pairs[(j + 1) % len(pairs)][0]:
                gap = _dist(pts[-1], nxt_pts[0])
                raise Problem(f"{src.describe()}: open loop: its end {fmt_point(pts[-1])} and "
                              f"the start of {nxt_src.describe()} are {fmt_length(gap)} {unit} "
                              f"apart (tolerance {fmt_length(tol)} {unit})")
            if _dist(pts[-1], nxt_pts[0]) > noise:
                gaps += 1
        loop_ends.append(pairs)

    index = _NodeIndex({n for n in node_of}, grid)
    table = _EdgeTable(tol)
    splits: dict[int, list[tuple[int, bool]]] = {}  # edge -> its pieces (canonical direction)
    flat: dict[int, list[Node]] = {}  # piece edge -> snapped interior vertices (canonical)

    def pieces_of(edge: int, depth: int = 0) -> list[tuple[int, bool]]:
        """The edge's leaf pieces in its canonical direction: split at the nodes near it, each
        piece (possibly an edge of another loop) split in turn, until nothing splits."""
        if edge not in splits:
            a, b = table.ends[edge]
            out: list[tuple[int, bool]] = []
            for u, v, poly in _split(table.polys[edge], a, b, index, tol):
                piece, rev = table.lookup(u, v, poly)
                if piece == edge or depth > 32:
                    out.append((piece, rev))
                    continue
                sub = pieces_of(piece, depth + 1)
                out += [(q, not r) for q, r in reversed(sub)] if rev else sub
            splits[edge] = out
        return splits[edge]

    def vertices_of(piece: int) -> list[Node]:
        if piece not in flat:
            a, b = table.ends[piece]
            verts: list[Node] = []
            for x, y in table.polys[piece][1:-1]:
                try:
                    n = (grid.index(x), grid.index(y))
                except ValueError:
                    raise Problem(f"a curve reaches {fmt_point((x, y))}, past the bounds of "
                                  f"assembly files (|x| <= 10^9)") from None
                if n != a and n != b and (not verts or verts[-1] != n):
                    verts.append(n)
            flat[piece] = verts
        return flat[piece]

    rings = []
    for loop, pairs in zip(loops, loop_ends):
        verts: list[Node] = []
        srcs: list[Source] = []
        for (pts, src), (a, b) in zip(loop.pieces, pairs):
            if a == b and len(pts) == 2:
                continue  # a piece shorter than the tolerance: its ends are one node
            poly = [index.pos[a], *pts[1:-1], index.pos[b]]
            edge, rev = table.lookup(a, b, poly)
            if rev:  # the edge's canonical direction runs from b to a
                seq = [(p, not r) for p, r in reversed(pieces_of(edge))]
            else:
                seq = pieces_of(edge)
            for piece, r in seq:
                u, v = table.ends[piece]
                inner = vertices_of(piece)
                if r:
                    u, inner = v, inner[::-1]
                for n in (u, *inner):
                    if not verts or verts[-1] != n:
                        verts.append(n)
                        srcs.append(src)
        while len(verts) > 1 and verts[-1] == verts[0]:
            verts.pop()
            srcs.pop()
        rings.append(_checked(ExactRing(verts, srcs, loop), grid, unit))
    return rings, gaps


def _checked(ring: ExactRing, grid: Grid, unit: str) -> ExactRing:
    v = ring.vertices
    if len(v) >= 3 and not ring_is_simple(v):
        raise Problem(_self_intersection(ring, grid))
    if len(v) < 3 or signed_area2(v) == 0:
        raise Problem(f"{ring.loop.source.describe()}: the loop has no area on the grid of the "
                      f"tolerance {grid.step:f} {unit} (smaller or thinner than the tolerance)")
    return ring


def _meeting(a: Node, b: Node, c: Node, d: Node) -> tuple[float, float]:
    """Where segments ab and cd (which meet) meet, for a message: their crossing, or an end of
    one lying on the other when they are parallel."""
    den = (b[0] - a[0]) * (d[1] - c[1]) - (b[1] - a[1]) * (d[0] - c[0])
    if den == 0:
        for p, (s, t) in ((c, (a, b)), (d, (a, b)), (a, (c, d)), (b, (c, d))):
            if _closest(p, s, t)[0] == 0:
                return p
        return c
    t = Fraction((c[0] - a[0]) * (d[1] - c[1]) - (c[1] - a[1]) * (d[0] - c[0]), den)
    return (float(a[0] + t * (b[0] - a[0])), float(a[1] + t * (b[1] - a[1])))


def _self_intersection(ring: ExactRing, grid: Grid) -> str:
    """The message naming the entities of two edges of a ring that meet (exact search)."""
    v, n = ring.vertices, len(ring.vertices)
    where = None
    for i in range(n):  # an edge folding back onto the previous one
        a, b, c = v[i - 1], v[i], v[(i + 1) % n]
        cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        dot = (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1])
        if cross == 0 and dot < 0:
            where = (i - 1) % n, i, b
            break
    if where is None:
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue
                if segments_intersect(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]):
                    where = i, j, _meeting(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n])
                    break
            if where is not None:
                break
    if where is None:  # ring_is_simple said no: cannot happen
        return f"{ring.loop.source.describe()}: self-intersection"
    i, j, p = where
    a, b = ring.sources[i], ring.sources[j]
    at = fmt_point((float(grid.step) * p[0], float(grid.step) * p[1]))
    if a == b:
        return f"{a.describe()}: self-intersection near {at}"
    return f"{a.describe()}: self-intersection: it meets {b.describe()} near {at}"
