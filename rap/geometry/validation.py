"""Exact geometric validation of an assembly.

``validate_assembly(assembly)`` returns None or raises ``rap.assembly.AssemblyError(source,
part_id, problem)`` for the first problem found, in this order:

1. a ring (outer boundary or hole) that is not simple: two non-adjacent edges meet, or two
   adjacent edges fold back onto each other;
2. a hole that is not strictly inside its polygon (crossing or touching the outer boundary, or
   outside it), or two holes that meet or nest;
3. two parts whose interiors overlap (touching along edges or at points is allowed).

Preconditions checked by ``rap.assembly`` already: >= 3 distinct vertices per ring, nonzero area.
Everything is integer arithmetic on the assembly scaled by the LCM of its denominators.

Complexity: O(sum of q^2) for the ring checks in the worst case (the spikes of a star, whose
edges' boxes all meet), done in numpy with a float filter and an exact fallback
(``rap.geometry.batch``: a 10,000-vertex star ring in about a second), and, for the overlap
check, O(n^2) bounding-box tests plus O(k_a k_b (q_a + q_b)) separating-axis work for each pair of
parts whose boxes overlap (k = convex pieces per part), i.e. O(n^2 q^2) in the worst case.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Sequence

import numpy as np

from rap.assembly import Assembly, AssemblyError
from rap.geometry.batch import MAX_EXACT_FLOAT_INT, box_pairs, crossing_signs
from rap.geometry.exact import IVec, IntAssembly, bounding_box, orient, to_integers
from rap.geometry.triangulate import convex_pieces

__all__ = ["validate_assembly", "validate_int_assembly", "segments_intersect",
           "point_in_ring", "convex_interiors_overlap", "ring_is_simple", "part_pieces",
           "assembly_pieces"]


def _on_segment(a, b, p) -> bool:
    """p (collinear with ab) lies on the closed segment ab."""
    return (min(a[0], b[0]) <= p[0] <= max(a[0], b[0])
            and min(a[1], b[1]) <= p[1] <= max(a[1], b[1]))


def segments_intersect(a, b, c, d) -> bool:
    """Do the closed segments ab and cd share at least one point? (exact)"""
    d1, d2 = orient(c, d, a), orient(c, d, b)
    d3, d4 = orient(a, b, c), orient(a, b, d)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True
    return ((d1 == 0 and _on_segment(c, d, a)) or (d2 == 0 and _on_segment(c, d, b))
            or (d3 == 0 and _on_segment(a, b, c)) or (d4 == 0 and _on_segment(a, b, d)))


def ring_is_simple(ring: Sequence[IVec]) -> bool:
    """True when the closed polyline has no self-intersection or self-touching (exact).

    Rings of more than ``_BATCH_MIN`` vertices whose coordinates are exact floats are checked with
    ``rap.geometry.batch`` (numpy sweep over the edges' boxes, a float filter, the exact integer
    test for the pairs it cannot decide); others pair by pair. The same answer either way.
    """
    n = len(ring)
    for i in range(n):  # adjacent edges (i, i+1) share b: they must not fold back
        a, b, c = ring[i], ring[(i + 1) % n], ring[(i + 2) % n]
        if orient(a, b, c) == 0 and (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]) < 0:
            return False
    limit = MAX_EXACT_FLOAT_INT // 2
    if n > _BATCH_MIN and all(-limit < v < limit for p in ring for v in p):
        return not _nonadjacent_edges_meet_batch(ring)
    edges = [(ring[i], ring[(i + 1) % n]) for i in range(n)]
    boxes = [(min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1])) for a, b in edges]
    for i in range(n):
        a, b = edges[i]
        x0, y0, x1, y1 = boxes[i]
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # adjacent through the closing vertex
            u0, v0, u1, v1 = boxes[j]
            if u0 > x1 or u1 < x0 or v0 > y1 or v1 < y0:
                continue
            if segments_intersect(a, b, *edges[j]):
                return False
    return True


_BATCH_MIN = 48  # below this many vertices, numpy's call overhead exceeds the pairwise loop


def _nonadjacent_edges_meet_batch(ring: Sequence[IVec]) -> bool:
    """Whether two non-adjacent edges of the ring share a point (see ``ring_is_simple``)."""
    n = len(ring)
    pts = np.array(ring, dtype=np.float64)  # exact: |v| < 2^52
    nxt = np.roll(pts, -1, axis=0)
    boxes = np.column_stack([np.minimum(pts[:, 0], nxt[:, 0]), np.minimum(pts[:, 1], nxt[:, 1]),
                             np.maximum(pts[:, 0], nxt[:, 0]), np.maximum(pts[:, 1], nxt[:, 1])])
    for i, j in box_pairs(boxes):
        gap = np.abs(i - j)
        keep = (gap != 1) & (gap != n - 1)  # adjacent edges share their vertex by definition
        i, j = i[keep], j[keep]
        crossing, undecided = crossing_signs(pts[i], nxt[i], pts[j], nxt[j])
        if crossing.any():
            return True
        for a, b in zip(i[undecided].tolist(), j[undecided].tolist()):
            if segments_intersect(ring[a], ring[(a + 1) % n], ring[b], ring[(b + 1) % n]):
                return True
    return False


def point_in_ring(p: Sequence[int], ring: Sequence[IVec]) -> int:
    """1 if p is strictly inside the ring, 0 if on its boundary, -1 if outside (exact)."""
    x, y = p
    inside = False
    n = len(ring)
    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        if orient(a, b, p) == 0 and _on_segment(a, b, p):
            return 0
        ay, by = a[1], b[1]
        if (ay > y) != (by > y):
            t = (b[0] - a[0]) * (y - ay) - (x - a[0]) * (by - ay)
            if (t > 0) == (by > ay):
                inside = not inside
    return 1 if inside else -1


def _segment_boxes(ring) -> np.ndarray:
    """(n, 4) float boxes (xmin, ymin, xmax, ymax) of a ring's edges, widened by one unit and
    the floats' relative rounding, so that a box test never drops a pair of edges that meet."""
    pts = np.array(ring, dtype=float)
    nxt = np.roll(pts, -1, axis=0)
    lo, hi = np.minimum(pts, nxt), np.maximum(pts, nxt)
    pad = 1.0 + 1e-12 * np.maximum(np.abs(lo), np.abs(hi))
    return np.hstack([lo - pad, hi + pad])


def _rings_meet(r1, r2) -> bool:
    """Do two rings' boundaries share a point? (exact; edges paired by a float box filter
    first, in blocks, so the cost is O(n1 n2 / 256) numpy work plus exact tests on the edge
    pairs whose boxes meet)"""
    b1, b2 = bounding_box(r1), bounding_box(r2)
    if b1[2] < b2[0] or b2[2] < b1[0] or b1[3] < b2[1] or b2[3] < b1[1]:
        return False
    n1, n2 = len(r1), len(r2)
    s1, s2 = _segment_boxes(r1), _segment_boxes(r2)
    for start in range(0, n1, 256):
        blk = s1[start:start + 256]
        hit = ((blk[:, None, 0] <= s2[None, :, 2]) & (s2[None, :, 0] <= blk[:, None, 2])
               & (blk[:, None, 1] <= s2[None, :, 3]) & (s2[None, :, 1] <= blk[:, None, 3]))
        for i, j in zip(*np.nonzero(hit)):
            i = int(i) + start
            j = int(j)
            if segments_intersect(r1[i], r1[(i + 1) % n1], r2[j], r2[(j + 1) % n2]):
                return True
    return False


def convex_interiors_overlap(P: Sequence[IVec], Q: Sequence[IVec]) -> bool:
    """Do the interiors of two convex polygons overlap? Separating axes over both edge sets.

    Interiors are disjoint iff some edge normal of P or Q gives projections whose open
    intervals are disjoint (the Minkowski difference's edges are parallel to P's and Q's).
    """
    for poly in (P, Q):
        n = len(poly)
        for i in range(n):
            ax, ay = poly[i]
            bx, by = poly[(i + 1) % n]
            nx, ny = ay - by, bx - ax
            if nx == 0 and ny == 0:
                continue
            pp = [nx * x + ny * y for x, y in P]
            qq = [nx * x + ny * y for x, y in Q]
            if max(pp) <= min(qq) or max(qq) <= min(pp):
                return False
    return True


def part_pieces(ia: IntAssembly) -> list[list[tuple[IVec, ...]]]:
    """Convex pieces of every part of an integer assembly (exact)."""
    return [convex_pieces(p.outer, p.holes) for p in ia.parts]


def validate_int_assembly(ia: IntAssembly) -> list[list[tuple[IVec, ...]]]:
    """Validate an integer assembly; returns the convex pieces of each part (reused by callers)."""
    src = ia.source
    for p in ia.parts:
        if not ring_is_simple(p.outer):
            raise AssemblyError(src, p.id, "polygon is self-intersecting")
        for j, h in enumerate(p.holes):
            if not ring_is_simple(h):
                raise AssemblyError(src, p.id, f"hole {j} is self-intersecting")
        for j, h in enumerate(p.holes):
            if _rings_meet(h, p.outer) or point_in_ring(h[0], p.outer) != 1:
                raise AssemblyError(src, p.id, f"hole {j} is not strictly inside the polygon")
        for j, h in enumerate(p.holes):
            for k in range(j + 1, len(p.holes)):
                g = p.holes[k]
                if _rings_meet(h, g) or point_in_ring(h[0], g) == 1 or point_in_ring(g[0], h) == 1:
                    raise AssemblyError(src, p.id, f"holes {j} and {k} overlap or touch")
    pieces = part_pieces(ia)
    boxes = [bounding_box(p.outer) for p in ia.parts]
    piece_boxes = [[bounding_box(pc) for pc in pcs] for pcs in pieces]
    n = len(ia.parts)
    order = sorted(range(n), key=lambda i: boxes[i][0])
    for oi, i in enumerate(order):  # sweep on x: only boxes whose interiors overlap are tested
        bi = boxes[i]
        for j in order[oi + 1:]:
            bj = boxes[j]
            if bj[0] >= bi[2]:
                break
            if bj[1] >= bi[3] or bi[1] >= bj[3] or bj[2] <= bi[0]:
                continue
            for P, bp in zip(pieces[i], piece_boxes[i]):
                for Q, bq in zip(pieces[j], piece_boxes[j]):
                    if bq[0] >= bp[2] or bp[0] >= bq[2] or bq[1] >= bp[3] or bp[1] >= bq[3]:
                        continue
                    if convex_interiors_overlap(P, Q):
                        a, b = sorted((i, j))
                        raise AssemblyError(src, ia.parts[a].id,
                                            f"overlaps part {ia.parts[b].id!r}")
    return pieces


def validate_assembly(assembly: Assembly) -> None:
    """Raise ``AssemblyError`` for the first exact geometric problem; None when valid. The
    integer assembly and its pieces are kept for ``assembly_pieces``."""
    ia = to_integers(assembly)
    pieces = validate_int_assembly(ia)
    _remember(_pieces_key(assembly), (ia, pieces))


_PIECES: OrderedDict[tuple[str, str], tuple[IntAssembly, list]] = OrderedDict()
_PIECES_SIZE = 8
_PIECES_LOCK = threading.Lock()


def _pieces_key(assembly: Assembly) -> tuple[str, str]:
    return assembly.geometry_hash, assembly.name


def _remember(key, value) -> None:
    with _PIECES_LOCK:
        _PIECES[key] = value
        _PIECES.move_to_end(key)
        while len(_PIECES) > _PIECES_SIZE:
            _PIECES.popitem(last=False)


def assembly_pieces(assembly: Assembly) -> tuple[IntAssembly, list[list[tuple[IVec, ...]]]]:
    """(the assembly scaled to integers, the convex pieces of each part), the one home of both:
    validation, the NDBG and the clearances share them, kept for the last ``_PIECES_SIZE``
    assemblies (by geometry hash and name; seconds for parts of thousands of vertices)."""
    key = _pieces_key(assembly)
    with _PIECES_LOCK:
        hit = _PIECES.get(key)
    if hit is None:
        ia = to_integers(assembly)
        hit = (ia, part_pieces(ia))
        _remember(key, hit)
    return hit
