"""Closed loops from drawn paths.

``join_loops(paths, tol)`` keeps closed paths as loops and joins open ones (loose LINE and ARC
entities, open polylines, open SVG subpaths) into closed loops, layer by layer, with ezdxf's
``edgeminer`` (``Deposit`` + ``find_all_simple_chains``: chains through vertices of degree 2,
ends within ``tol`` connected). A chain that does not close is an open loop (its free end and the
distance to the nearest other free end are named), a vertex where three or more loose ends meet
is a branch; both are a ``Problem``. The loops' pieces keep their float points: the exact rings
on the tolerance grid are ``rap.cad.rings.exact_rings``.

Cost: linear in the points of closed paths; the loose paths of a layer go through edgeminer's
chain search over their ends.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

from rap.cad.drawing import DrawnPath, Point, Problem, Source, distance, fmt_length, fmt_point

__all__ = ["Loop", "join_loops"]


@dataclass
class Loop:
    """A closed sequence of pieces (float polylines, consecutive ends within the tolerance)."""

    pieces: list[tuple[list[Point], Source]]
    source: Source  # the entity that names the loop: the first in file order
    layer: str | None


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
    total = sum(distance(a, b) for a, b in zip(pts, pts[1:]))
    run = 0.0
    for i in range(1, len(pts) - 1):
        run += distance(pts[i - 1], pts[i])
        if run >= total / 2:
            return i
    return len(pts) - 2


def _span_under(p: Point, src: Source, paths: list[DrawnPath], tol: float) -> Source | None:
    """The source of another path whose polyline passes within ``tol`` of ``p`` away from its
    ends (an end met on a span: a T-junction), or None."""
    from rap.cad.edges import closest

    for path in paths:
        if path.source == src or (not path.closed and min(distance(p, path.start),
                                                            distance(p, path.end)) <= tol):
            continue
        for piece in path.pieces:
            for a, b in zip(piece, piece[1:]):
                if closest(p, a, b)[0] <= tol:
                    return path.source
    return None


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
        if p.closed or (not single and distance(p.start, p.end) <= tol):
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
                    raise Problem(f"{len(meet)} loose ends meet at "
                                  f"{fmt_point((v.x, v.y), tol)} ("
                                  + ", ".join(s.describe() for s in meet[:4])
                                  + "): a loop cannot branch; --parts auto reads shared edges "
                                    "drawn once as faces")
            free.extend(((v.x, v.y), src) for v, src in ends)
            bad.append(len(free) - 2)
        if bad:
            i = bad[0]
            (p, src) = free[i]
            others = [(distance(p, q), s, q) for j, (q, s) in enumerate(free) if j != i]
            gap, other, q = min(others, key=lambda t: t[0])
            on = _span_under(p, src, paths, tol)
            if on is not None:
                raise Problem(f"{src.describe()}: the end at {fmt_point(p, tol)} lies on "
                              f"{on.describe()} (a T-junction): loops cannot end on a span; "
                              f"--parts auto reads cut lines drawn once as faces")
            raise Problem(f"{src.describe()}: open loop: the end at {fmt_point(p, tol)} meets "
                          f"nothing within the tolerance {fmt_length(tol, tol)} {unit}; the gap "
                          f"to the nearest free end, {fmt_point(q, tol)} of {other.describe()}, "
                          f"is {fmt_length(gap, tol)} {unit}")
    loops.sort(key=lambda lp: lp.source.order)
    return loops
