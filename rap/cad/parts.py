"""Parts from exact rings: holes by containment, one part per outer loop or per layer.

``nest(rings)`` finds, for every ring, the rings whose interior holds it, exactly: ring B lies in
ring A when B's box is within A's, a point strictly inside B (``interior_point``, a rational) is
strictly inside A (``rap.geometry.validation.point_in_ring``) and B's area is smaller than A's
(or equal, for the same loop drawn twice or a peg's outline that is also its hole's: then the
later one in the file lies in the earlier). Rings whose boundaries cross are not nested; the
validation of the assembly names them as overlapping parts.

``group_parts(rings, by)``: with ``by="loop"`` (the default) a ring held by an even number of
rings is the outline of a part and a ring held by an odd number is a hole of the smallest ring
holding it (a plate's hole, and the peg drawn in it, which is a part again). With ``by="layer"``
the nesting is taken within each layer (DXF layer, SVG top-level group): one outline per layer,
the rings inside it its holes; a layer with two outlines, or an island inside a hole, is a
``Problem``. A hole that is its outline drawn twice is a ``Problem`` naming both entities.

Part ids: per layer, the layer's name; per loop, the layer (DXF) or element id (SVG) when it names
one part only, else ``NAME:HANDLE`` (DXF) or ``ID:SUBPATH`` (SVG); commas become ``_`` and ids
are cut to 100 characters. Rings come out canonical (counter-clockwise outlines, clockwise holes,
each starting at its smallest vertex) and parts sorted by file order, so an import is
deterministic. Cost: O(R^2) box tests for R rings plus O(q) exact work for each box-nested pair.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from fractions import Fraction

from rap.assembly import LIMITS
from rap.cad.drawing import Problem, Source
from rap.cad.edges import Node
from rap.cad.rings import ExactRing
from rap.geometry.exact import bounding_box, orient
from rap.geometry.validation import point_in_ring

__all__ = ["ExactPart", "interior_point", "nest", "group_parts", "canonical_ring",
           "loop_part_ids"]


@dataclass
class ExactPart:
    """A part of grid indices: its id, outline, holes and the entities that drew them."""

    id: str
    outer: list[Node]
    holes: list[list[Node]]
    source: Source
    layer: str | None
    hole_sources: list[Source]


def interior_point(ring: list[Node]) -> tuple[Fraction, Fraction]:
    """A point strictly inside a simple ring of nonzero area (exact; O(len(ring))).

    At the lowest-leftmost vertex v (a convex corner) with neighbours a and c: the centroid of
    triangle a v c when no other vertex lies in it, else the midpoint of v and the vertex in it
    farthest from the line ac (then segment v q is a diagonal inside the ring).
    """
    n = len(ring)
    i = min(range(n), key=lambda k: ring[k])
    a, v, c = ring[i - 1], ring[i], ring[(i + 1) % n]
    s = 1 if orient(a, v, c) > 0 else -1
    best, best_d = None, None
    for k, q in enumerate(ring):
        if k in (i, (i - 1) % n, (i + 1) % n):
            continue
        if s * orient(a, v, q) >= 0 and s * orient(v, c, q) >= 0 and s * orient(c, a, q) >= 0:
            d = s * orient(c, a, q)
            if best_d is None or d > best_d:
                best, best_d = q, d
    if best is None:
        return (Fraction(a[0] + v[0] + c[0], 3), Fraction(a[1] + v[1] + c[1], 3))
    return (Fraction(v[0] + best[0], 2), Fraction(v[1] + best[1], 2))


def nest(rings: list[ExactRing]) -> list[list[int]]:
    """For each ring, the indices of the rings it lies in (see the module doc)."""
    boxes = [bounding_box(r.vertices) for r in rings]
    areas = [abs(r.area2) for r in rings]
    inner = [interior_point(r.vertices) for r in rings]
    held: list[list[int]] = [[] for _ in rings]
    order = sorted(range(len(rings)), key=lambda k: boxes[k][0])
    for b in range(len(rings)):
        bx = boxes[b]
        for a in order:
            ax = boxes[a]
            if ax[0] > bx[0]:
                break  # no later box starts left of b's
            if a == b or ax[1] > bx[1] or ax[2] < bx[2] or ax[3] < bx[3]:
                continue
            if areas[b] > areas[a] or (areas[b] == areas[a] and a > b):
                continue
            if point_in_ring(inner[b], rings[a].vertices) == 1:
                held[b].append(a)
    return held


def canonical_ring(ring: list[Node], ccw: bool) -> list[Node]:
    from rap.assembly import signed_area2

    if (signed_area2(ring) > 0) != ccw:
        ring = ring[::-1]
    k = min(range(len(ring)), key=lambda i: ring[i])
    return ring[k:] + ring[:k]


def _clean_id(text: str) -> str:
    return text.replace(",", "_")[:LIMITS.max_id_chars] or "_"


def _layer_key(ring: ExactRing) -> str:
    """The layer of a ring: its DXF layer or SVG top-level group; an SVG element outside groups
    is a layer of its own."""
    return ring.loop.layer if ring.loop.layer is not None else ring.loop.source.name()


def loop_part_ids(sources: list[Source]) -> list[str]:
    """The ids of parts drawn as loops by these entities (in order): the entity's name (DXF
    layer, SVG id) when it names one part only, else ``NAME:TAG``; unique."""
    names: dict[str, int] = defaultdict(int)
    for src in sources:
        names[_clean_id(src.name())] += 1
    out: list[str] = []
    used: set[str] = set()
    for src in sources:
        base = _clean_id(src.name())
        pid = base if names[base] == 1 else _clean_id(f"{base}:{src.tag()}")
        k = 2
        while pid in used:
            pid, k = _clean_id(f"{base}:{src.tag()}.{k}"), k + 1
        used.add(pid)
        out.append(pid)
    return out


def group_parts(rings: list[ExactRing], by: str = "loop") -> list[ExactPart]:
    """The parts of the rings, per loop or per layer (see the module doc)."""
    if by not in ("loop", "layer"):
        raise ValueError(by)
    groups: dict = defaultdict(list)
    for k, r in enumerate(rings):
        groups[_layer_key(r) if by == "layer" else None].append(k)
    parts: list[tuple[int, list[int]]] = []  # (outer ring, hole rings)
    for key, members in groups.items():
        sub = [rings[k] for k in members]
        held = nest(sub)
        depth = [len(h) for h in held]
        outers = [i for i in range(len(sub)) if depth[i] % 2 == 0]
        if by == "layer":
            deep = [i for i in range(len(sub)) if depth[i] >= 2]
            if len(outers) > 1 or deep:
                names = ", ".join(sub[i].loop.source.describe() for i in (outers + deep)[:3])
                raise Problem(f"layer {key!r} has {len(outers)} separate outlines ({names}); "
                              f"with --parts layer a layer is one part with holes: use "
                              f"--parts loop, or move the loops to layers of their own")
        holes: dict[int, list[int]] = {i: [] for i in outers}
        for i in range(len(sub)):
            if depth[i] % 2 == 1:
                parent = max(held[i], key=lambda a: depth[a])
                if abs(sub[i].area2) == abs(sub[parent].area2):
                    raise Problem(f"{sub[parent].loop.source.describe()} and "
                                  f"{sub[i].loop.source.describe()} are the same loop drawn "
                                  f"twice")
                holes[parent].append(i)
        for i in outers:
            parts.append((members[i], [members[h] for h in holes[i]]))
    parts.sort(key=lambda p: rings[p[0]].loop.source.order)

    ids = loop_part_ids([rings[outer].loop.source for outer, _ in parts])
    out: list[ExactPart] = []
    for (outer, hole_ids), pid in zip(parts, ids):
        src = rings[outer].loop.source
        if by == "layer":
            pid = _clean_id(_layer_key(rings[outer]))
        holes = sorted(((canonical_ring(rings[h].vertices, ccw=False), rings[h].loop.source)
                        for h in hole_ids), key=lambda hs: hs[0][0])
        out.append(ExactPart(pid, canonical_ring(rings[outer].vertices, ccw=True),
                             [h for h, _ in holes], src, rings[outer].loop.layer,
                             [s for _, s in holes]))
    return out
