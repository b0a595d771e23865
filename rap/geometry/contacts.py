"""Contacts between parts: the pieces of the common boundary of two parts, exact.

Precondition: the parts' interiors are disjoint (``rap.geometry.validation`` checks it). Every
ring is walked with the part's interior on its left (outer rings counter-clockwise, holes
clockwise, as ``rap.assembly`` normalises them), so two edges that touch along a segment run in
opposite directions on one line, and the outward normal of an edge ``p -> q`` is
``(q - p)`` turned right: ``(dy, -dx)``.

A ``Contact`` of parts ``a`` and ``b`` is a segment ``p -- q`` of their common boundary with the
outward normal of ``a``'s side, pointing from ``a`` into ``b``, as a primitive integer direction
(so it does not change when the assembly is translated or scaled). Two kinds are found:

- *edge contacts*: an edge of ``a`` and an edge of ``b`` on one line, running in opposite
  directions, overlapping in a segment of positive length (maximal: collinear pieces that meet
  end to end are merged);
- *point contacts* (``p == q``): a vertex of one part strictly inside an edge of the other and
  not on any edge contact of the pair.

**Vertex-vertex touching is ignored** (two parts meeting only at a common vertex, or two collinear
edges meeting at a single end point): the contact normal is undefined there, and leaving it out
is conservative for statics (a contact that is dropped cannot carry load).

Exact: coordinates are scaled to integers (``rap.geometry.exact.to_integers``); collinearity,
direction and overlap are integer cross and dot products; no epsilon. The points are given back in
the assembly's own coordinates as ``Fraction``.

Cost: ``contact_table`` sorts the parts' bounding boxes and tests only pairs whose closed boxes
meet, each in O(n_a n_b) for rings of n_a and n_b edges: O(P log P + sum over such pairs of
n_a n_b). It is memoised per ``Assembly.geometry_hash`` (the last 32 assemblies).
``contacts_within(assembly, ids)`` then costs O(sum of the degrees of ``ids`` in the contact
graph).

``meeting_pairs(assembly)`` is the plain question without the normals: the pairs of parts whose
closed polygons share a point, **vertex-vertex touching included** (what decides whether an
operation touches anything, ``rap.geometry.ndbg.is_free_operation``). Exact through the filtered
segment predicates of ``rap.geometry.batch``: O(V log V + k) numpy work for V vertices and k
pairs of segment boxes that meet, plus an exact integer test for each pair the filter cannot
decide; memoised like the table.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from fractions import Fraction
from types import MappingProxyType
from typing import Iterable, Mapping

from rap.assembly import Assembly
from rap.geometry.exact import IntPart, bounding_box, cross, dot, primitive, to_integers

__all__ = ["Contact", "contact_segments", "contact_table", "contacts_within", "touching",
           "meeting_pairs"]

FPoint = tuple[Fraction, Fraction]


@dataclass(frozen=True)
class Contact:
    """A piece ``p -- q`` of the common boundary of two parts (``p == q``: a point contact);
    ``normal`` is the primitive outward normal of the first part's side, pointing into the
    second part."""

    p: FPoint
    q: FPoint
    normal: tuple[Fraction, Fraction]

    @property
    def is_point(self) -> bool:
        return self.p == self.q


_IPoint = tuple[int, int]
# an integer contact: (p, q, normal) with p, q integer points, normal primitive
_IContact = tuple[_IPoint, _IPoint, _IPoint]


def _edges(part: IntPart):
    for ring in part.rings():
        n = len(ring)
        for i in range(n):
            yield ring[i], ring[(i + 1) % n]


def _edge_contacts(a: IntPart, b: IntPart) -> list[_IContact]:
    """Overlaps of positive length of opposite collinear edges, oriented along a's edge."""
    out = []
    for p, q in _edges(a):
        dx, dy = q[0] - p[0], q[1] - p[1]
        length2 = dot(dx, dy, dx, dy)
        for r, s in _edges(b):
            if cross(dx, dy, r[0] - p[0], r[1] - p[1]) or cross(dx, dy, s[0] - p[0], s[1] - p[1]):
                continue  # not on a's line
            if dot(dx, dy, s[0] - r[0], s[1] - r[1]) >= 0:
                continue  # same direction: interiors on one side (not a contact)
            # parameters along p -> q, scaled by |q - p|^2: p at 0, q at length2
            ts = dot(dx, dy, s[0] - p[0], s[1] - p[1])
            tr = dot(dx, dy, r[0] - p[0], r[1] - p[1])
            lo, hi = max(0, ts), min(length2, tr)
            if lo >= hi:
                continue  # no overlap, or a single common point (vertex-vertex: ignored)
            start = p if lo == 0 else s
            end = q if hi == length2 else r
            out.append((start, end, primitive((dy, -dx))))
    return out


def _merge(contacts: list[_IContact]) -> list[_IContact]:
    """Merge collinear contacts with one normal that meet end to end (O(k^2), k small)."""
    items = list(contacts)
    merged = True
    while merged:
        merged = False
        for i in range(len(items)):
            for j in range(len(items)):
                if i != j and items[i][2] == items[j][2] and items[i][1] == items[j][0]:
                    items[i] = (items[i][0], items[j][1], items[i][2])
                    del items[j]
                    merged = True
                    break
            if merged:
                break
    return items


def _on_segment(v: _IPoint, p: _IPoint, q: _IPoint) -> bool:
    """Is v on the closed segment p -- q (p != q)?"""
    if cross(q[0] - p[0], q[1] - p[1], v[0] - p[0], v[1] - p[1]):
        return False
    t = dot(q[0] - p[0], q[1] - p[1], v[0] - p[0], v[1] - p[1])
    return 0 <= t <= dot(q[0] - p[0], q[1] - p[1], q[0] - p[0], q[1] - p[1])


def _strictly_inside_edge(v: _IPoint, p: _IPoint, q: _IPoint) -> bool:
    return _on_segment(v, p, q) and v != p and v != q


def _point_contacts(a: IntPart, b: IntPart, segments: list[_IContact]) -> list[_IContact]:
    """Vertices of one part strictly inside an edge of the other, not on a segment contact."""
    out: list[_IContact] = []
    seen: set[_IPoint] = set()

    def covered(v):
        return v in seen or any(_on_segment(v, s, t) for s, t, _ in segments)

    for first, second, sign in ((a, b, -1), (b, a, 1)):
        # a vertex v of `first` inside an edge of `second`; the edge's outward normal points
        # from `second` into `first`: into b when second is a (sign 1), so negate otherwise
        verts = {v for ring in first.rings() for v in ring}
        for p, q in _edges(second):
            for v in verts:
                if _strictly_inside_edge(v, p, q) and not covered(v):
                    n = primitive((q[1] - p[1], p[0] - q[0]))
                    out.append((v, v, (sign * n[0], sign * n[1])))
                    seen.add(v)
    return out


def _pair_contacts(a: IntPart, b: IntPart) -> list[_IContact]:
    segments = _merge(_edge_contacts(a, b))
    return sorted(segments) + sorted(_point_contacts(a, b, segments))


def _to_contact(c: _IContact, scale: int) -> Contact:
    (px, py), (qx, qy), (nx, ny) = c
    return Contact((Fraction(px, scale), Fraction(py, scale)),
                   (Fraction(qx, scale), Fraction(qy, scale)), (Fraction(nx), Fraction(ny)))


def contact_segments(assembly: Assembly, a: str, b: str) -> tuple[Contact, ...]:
    """The contacts of parts ``a`` and ``b`` (normals from ``a`` into ``b``); () if they do not
    touch. Read from the memoised table (``contact_table``). ``KeyError`` for an unknown id."""
    assembly.index(a), assembly.index(b)
    if a == b:
        raise ValueError(f"a part does not touch itself: {a!r}")
    table = contact_table(assembly)
    if a < b:
        return table.get((a, b), ())
    return tuple(Contact(c.p, c.q, (-c.normal[0], -c.normal[1])) for c in table.get((b, a), ()))


@dataclass(frozen=True)
class _Table:
    pairs: Mapping[tuple[str, str], tuple[Contact, ...]]
    neighbours: Mapping[str, tuple[str, ...]]


_CACHE: OrderedDict[str, _Table] = OrderedDict()
_CACHE_SIZE = 32
_LOCK = threading.Lock()


def _build(assembly: Assembly) -> _Table:
    ia = to_integers(assembly)
    parts = sorted(ia.parts, key=lambda p: bounding_box(p.outer)[0])
    boxes = {p.id: bounding_box(p.outer) for p in parts}
    pairs: dict[tuple[str, str], tuple[Contact, ...]] = {}
    for i, pa in enumerate(parts):
        ax0, ay0, ax1, ay1 = boxes[pa.id]
        for pb in parts[i + 1:]:
            bx0, by0, bx1, by1 = boxes[pb.id]
            if bx0 > ax1:
                break  # sorted by min x: no later box meets a's
            if by0 > ay1 or by1 < ay0 or bx1 < ax0:
                continue
            first, second = (pa, pb) if pa.id < pb.id else (pb, pa)
            found = _pair_contacts(first, second)
            if found:
                pairs[(first.id, second.id)] = tuple(_to_contact(c, ia.scale) for c in found)
    neighbours: dict[str, list[str]] = {pid: [] for pid in assembly.ids}
    for a, b in sorted(pairs):
        neighbours[a].append(b)
        neighbours[b].append(a)
    return _Table(MappingProxyType(dict(sorted(pairs.items()))),
                  MappingProxyType({k: tuple(v) for k, v in neighbours.items()}))


def _table(assembly: Assembly) -> _Table:
    key = assembly.geometry_hash
    with _LOCK:
        hit = _CACHE.get(key)
        if hit is not None:
            _CACHE.move_to_end(key)
            return hit
    table = _build(assembly)
    with _LOCK:
        _CACHE[key] = table
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return table


def contact_table(assembly: Assembly) -> Mapping[tuple[str, str], tuple[Contact, ...]]:
    """Every touching pair ``(a, b)`` with ``a < b`` and its contacts (normals from ``a`` into
    ``b``), as a read-only mapping in sorted order. Memoised per geometry hash (see the module doc
    for the cost)."""
    return _table(assembly).pairs


def touching(assembly: Assembly, part: str) -> tuple[str, ...]:
    """The parts that touch ``part`` (by a segment or point contact), sorted."""
    return _table(assembly).neighbours[part]


def contacts_within(assembly: Assembly,
                    ids: Iterable[str]) -> dict[tuple[str, str], tuple[Contact, ...]]:
    """The touching pairs ``(a, b)``, ``a < b``, of the parts ``ids`` and their contacts: the
    memoised table restricted to the subset, O(sum of the degrees of ``ids``). ``KeyError`` for an
    unknown id."""
    table = _table(assembly)
    chosen = set(ids)
    out = {}
    for a in sorted(chosen):
        for b in table.neighbours[a]:
            if a < b and b in chosen:
                out[(a, b)] = table.pairs[(a, b)]
    return out


_MEETING: OrderedDict[str, frozenset] = OrderedDict()


def _meeting(assembly: Assembly) -> frozenset[tuple[str, str]]:
    import numpy as np

    from rap.geometry.batch import box_pairs, crossing_signs
    from rap.geometry.validation import segments_intersect

    ia = to_integers(assembly)
    owner, segs = [], []
    for k, part in enumerate(ia.parts):
        for p, q in _edges(part):
            owner.append(k)
            segs.append((p, q))
    if len(ia.parts) < 2:
        return frozenset()
    owner_a = np.asarray(owner)
    pts = np.asarray(segs, dtype=np.float64)  # [n, 2 ends, 2]: exact (|x| < 2^53, rap.assembly)
    boxes = np.concatenate([pts.min(axis=1), pts.max(axis=1)], axis=1)
    found: set[tuple[int, int]] = set()
    for i, j in box_pairs(boxes):
        keep = owner_a[i] != owner_a[j]
        i, j = i[keep], j[keep]
        crossing, unsure = crossing_signs(pts[i, 0], pts[i, 1], pts[j, 0], pts[j, 1])
        for a, b in zip(i[crossing], j[crossing]):  # a proper crossing: not a valid assembly's
            found.add(tuple(sorted((owner[a], owner[b]))))
        for a, b in zip(i[unsure], j[unsure]):
            pair = tuple(sorted((owner[a], owner[b])))
            if pair not in found and segments_intersect(*segs[a], *segs[b]):
                found.add(pair)
    ids = ia.ids
    return frozenset(tuple(sorted((ids[a], ids[b]))) for a, b in found)


def meeting_pairs(assembly: Assembly) -> frozenset[tuple[str, str]]:
    """The pairs ``(a, b)``, ``a < b``, of parts whose closed polygons share at least one point:
    a segment or point contact, or two vertices that coincide (module doc). Exact; memoised per
    geometry hash."""
    key = assembly.geometry_hash
    with _LOCK:
        hit = _MEETING.get(key)
        if hit is not None:
            _MEETING.move_to_end(key)
            return hit
    pairs = _meeting(assembly)
    with _LOCK:
        _MEETING[key] = pairs
        while len(_MEETING) > _CACHE_SIZE:
            _MEETING.popitem(last=False)
    return pairs
