"""Exact rings of a drawing's loops on the tolerance grid, with exact contacts.

``exact_rings(loops, grid)`` turns the loops of ``rap.cad.loops.join_loops`` into rings of integer
grid indices (coordinate = index * step), through the shared boundaries of ``rap.cad.edges``: the
ends of all pieces merged into nodes (a joint of a loop whose ends are apart by more than
rounding, 1e-9 of the drawing's extent, and at most the tolerance is a gap closed, counted), each
piece looked up as an edge and split at the nodes near it until nothing splits, and each distinct
piece's interior points (its flattening, within the chordal tolerance) *flattened once*: snapped
once, in canonical direction, and every loop that uses the piece takes that vertex list, reversed
where it runs the other way.

So two parts that share a boundary in the drawing share its vertices exactly, and their contact is
exact (collinear edges, no gap, no overlap). Each ring is then checked exactly: at least 3
vertices and a nonzero area after snapping, and simple (``rap.geometry.validation.ring_is_simple``);
a self-intersection is named by the two entities whose edges meet. Every problem is a ``Problem``.

Cost: O(E log E + P * k) for E piece ends and P flattened points, k the nodes near an edge's box
(timings: ``python benchmarks/cad_import.py``, docs/RESULTS.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from rap.assembly import signed_area2
from rap.cad.drawing import Point, Problem, Source, distance, fmt_length, fmt_point
from rap.cad.edges import EdgeTable, Node, NodeIndex, closest, merge_nodes, split_at_nodes
from rap.cad.loops import Loop
from rap.cad.snap import Grid
from rap.geometry.validation import ring_is_simple, segments_intersect

__all__ = ["ExactRing", "exact_rings"]


@dataclass
class ExactRing:
    """A simple ring of grid indices; ``sources[i]`` drew the edge from vertex i to i + 1."""

    vertices: list[Node]
    sources: list[Source]
    loop: Loop

    @property
    def area2(self) -> int:
        return int(signed_area2(self.vertices))


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
                    raise Problem(f"{src.describe()}: coordinate {fmt_point(p, tol)} is past the "
                                  f"bounds of assembly files (|x| <= 10^9)") from None
            ends += (pts[0], pts[-1])
    node_of = merge_nodes(ends, tol, grid)
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
                gap = distance(pts[-1], nxt_pts[0])
                raise Problem(f"{src.describe()}: open loop: its end {fmt_point(pts[-1], tol)} and "
                              f"the start of {nxt_src.describe()} are {fmt_length(gap, tol)} {unit} "
                              f"apart (tolerance {fmt_length(tol, tol)} {unit})")
            if distance(pts[-1], nxt_pts[0]) > noise:
                gaps += 1
        loop_ends.append(pairs)

    index = NodeIndex({n for n in node_of}, grid)
    table = EdgeTable(tol)
    splits: dict[int, list[tuple[int, bool]]] = {}  # edge -> its pieces (canonical direction)
    flat: dict[int, list[Node]] = {}  # piece edge -> snapped interior vertices (canonical)

    def pieces_of(edge: int, depth: int = 0) -> list[tuple[int, bool]]:
        """The edge's leaf pieces in its canonical direction: split at the nodes near it, each
        piece (possibly an edge of another loop) split in turn, until nothing splits."""
        if edge not in splits:
            a, b = table.ends[edge]
            out: list[tuple[int, bool]] = []
            for u, v, poly in split_at_nodes(table.polys[edge], a, b, index, tol):
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
                    raise Problem(f"a curve reaches {fmt_point((x, y), tol)}, past the bounds of "
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
            if closest(p, s, t)[0] == 0:
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
    at = fmt_point((float(grid.step) * p[0], float(grid.step) * p[1]), grid.step_float)
    if a == b:
        return f"{a.describe()}: self-intersection near {at}"
    return f"{a.describe()}: self-intersection: it meets {b.describe()} near {at}"
