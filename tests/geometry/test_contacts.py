"""Exact contact segments (rap.geometry.contacts): small cases with known answers, and properties
checked against shapely's boundary intersections (an independent float computation)."""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction as F

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Point, Polygon

from rap.assembly import Assembly, Part
from rap.geometry.contacts import (Contact, contact_segments, contact_table, contacts_within,
                                   meeting_pairs, touching)
from rap.geometry.families import generate
from rap.geometry.families.simple import random_tiling
from tests.geometry.fixtures import (CORNER_TOUCH, FAR_APART, FRAMED, GRID3, TWO_SIDE_BY_SIDE,
                                     make, square)


def pt(x, y):
    return (F(x), F(y))


def c(p, q, n):
    return Contact(pt(*p), pt(*q), pt(*n))


# a square with a triangle standing on its top edge by one vertex
VERTEX_ON_EDGE = make("vertex-on-edge", [
    {"id": "a", "polygon": square(0, 0, 4)},
    {"id": "b", "polygon": [[2, 4], [4, 6], [0, 6]]},
])
# b sits on a's top edge, shifted right by half its width
PARTIAL = make("partial", [{"id": "a", "polygon": square(0, 0, 2)},
                           {"id": "b", "polygon": square(1, 2, 2)}])
# a's top edge is split by a collinear vertex, b's bottom edge by another: one merged contact
SPLIT = make("split", [
    {"id": "a", "polygon": [[0, 0], [4, 0], [4, 1], [3, 1], [0, 1]]},
    {"id": "b", "polygon": [[0, 1], [1, 1], [4, 1], [4, 2], [0, 2]]},
])
H = Decimal("0.5")  # parse_assembly reads decimals exactly, never through a binary float
HALVES = make("halves", [{"id": "a", "polygon": [[0, 0], [H, 0], [H, H], [0, H]]},
                         {"id": "b", "polygon": [[H, 0], [1, 0], [1, H], [H, H]]}])

CASES = [
    (TWO_SIDE_BY_SIDE, "a", "b", (c((1, 0), (1, 1), (1, 0)),)),
    (PARTIAL, "a", "b", (c((2, 2), (1, 2), (0, 1)),)),
    (VERTEX_ON_EDGE, "a", "b", (c((2, 4), (2, 4), (0, 1)),)),
    (VERTEX_ON_EDGE, "b", "a", (c((2, 4), (2, 4), (0, -1)),)),
    (CORNER_TOUCH, "a", "b", ()),  # vertex-vertex: ignored
    (FAR_APART, "a", "b", ()),
    (SPLIT, "a", "b", (c((4, 1), (0, 1), (0, 1)),)),
    (HALVES, "a", "b", (Contact((F(1, 2), F(0)), (F(1, 2), F(1, 2)), pt(1, 0)),)),
]


@pytest.mark.parametrize("asm,a,b,expected", CASES, ids=lambda v: getattr(v, "name", None))
def test_known_contacts(asm, a, b, expected):
    assert contact_segments(asm, a, b) == expected


def test_hole_ring_contacts():
    got = contact_segments(FRAMED, "core", "frame")
    assert sorted(got, key=lambda k: k.normal) == sorted([
        c((3, 7), (3, 3), (-1, 0)), c((3, 3), (7, 3), (0, -1)),
        c((7, 3), (7, 7), (1, 0)), c((7, 7), (3, 7), (0, 1))], key=lambda k: k.normal)
    # seen from the frame, normals point inwards into the core
    assert {k.normal for k in contact_segments(FRAMED, "frame", "core")} == {
        pt(1, 0), pt(0, 1), pt(-1, 0), pt(0, -1)}


def test_table_subsets_and_neighbours():
    table = contact_table(GRID3)
    assert all(a < b for a, b in table)
    assert len(table) == 12  # 3 x 3 unit squares: 6 horizontal + 6 vertical shared edges
    sub = contacts_within(GRID3, ["r0c0", "r0c1", "r1c1"])
    assert sorted(sub) == [("r0c0", "r0c1"), ("r0c1", "r1c1")]
    assert touching(GRID3, "r1c1") == ("r0c1", "r1c0", "r1c2", "r2c1")
    assert contact_table(GRID3) is table  # memoised
    with pytest.raises(KeyError):
        contact_segments(GRID3, "r0c0", "nope")
    with pytest.raises(KeyError):
        contacts_within(GRID3, ["nope"])


def _moved(asm: Assembly, k: int, tx: int, ty: int) -> Assembly:
    return Assembly(asm.name, tuple(
        Part(p.id, *[tuple((k * x + tx, k * y + ty) for x, y in ring) for ring in p.rings()[:1]],
             tuple(tuple((k * x + tx, k * y + ty) for x, y in h) for h in p.holes))
        for p in asm.parts))


def _sample(seed: int, kind: int) -> Assembly:
    rng = np.random.default_rng(seed)
    if kind == 0:
        return random_tiling(int(rng.integers(2, 9)), rng)
    if kind == 1:
        return generate("wall", seed, gap=int(rng.integers(0, 2)))
    return make("shapes", [{"id": "a", "polygon": square(0, 0, 4)},
                           {"id": "b", "polygon": [[int(rng.integers(1, 4)), 4], [5, 7], [0, 7]]},
                           FRAMED_PARTS[0], FRAMED_PARTS[1]])


FRAMED_PARTS = [{"id": "frame", "polygon": square(10, 0, 10), "holes": [square(13, 3, 4)]},
                {"id": "core", "polygon": square(13, 3, 4)}]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10 ** 6), st.integers(0, 2), st.integers(1, 7),
       st.integers(-50, 50), st.integers(-50, 50))
def test_invariant_under_integer_translation_and_scaling(seed, kind, k, tx, ty):
    asm = _sample(seed, kind)
    moved = _moved(asm, k, tx, ty)

    def image(ct):
        return Contact((k * ct.p[0] + tx, k * ct.p[1] + ty), (k * ct.q[0] + tx, k * ct.q[1] + ty),
                       ct.normal)

    want = {pair: tuple(image(ct) for ct in cs) for pair, cs in contact_table(asm).items()}
    assert dict(contact_table(moved)) == want


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10 ** 6), st.integers(0, 2))
def test_agrees_with_shapely(seed, kind):
    """Total contact length per pair = the length of shapely's boundary intersection; every
    normal points out of a and into b; swapping the parts negates the normals."""
    asm = _sample(seed, kind)
    polys = {p.id: Polygon(p.float_outer(), p.float_holes()) for p in asm.parts}
    table = contact_table(asm)
    for i, a in enumerate(asm.ids):
        for b in asm.ids[i + 1:]:
            lo, hi = sorted((a, b))
            cs = table.get((lo, hi), ())
            shared = polys[lo].boundary.intersection(polys[hi].boundary).length
            length = sum(float(((ct.q[0] - ct.p[0]) ** 2 + (ct.q[1] - ct.p[1]) ** 2) ** 0.5)
                         for ct in cs)
            assert length == pytest.approx(shared, abs=1e-9)
            for ct in cs:
                mx, my = float(ct.p[0] + ct.q[0]) / 2, float(ct.p[1] + ct.q[1]) / 2
                nx, ny = float(ct.normal[0]), float(ct.normal[1])
                h = 1e-4 / (nx * nx + ny * ny) ** 0.5
                if ct.p != ct.q:
                    assert polys[hi].contains(Point(mx + h * nx, my + h * ny))
                    assert polys[lo].contains(Point(mx - h * nx, my - h * ny))
                else:  # a point contact: the side of the edge it lies on
                    assert (polys[hi].intersects(Point(mx + h * nx, my + h * ny))
                            or polys[lo].intersects(Point(mx - h * nx, my - h * ny)))
            back = contact_segments(asm, hi, lo)
            assert [(k.p, k.q, (-k.normal[0], -k.normal[1])) for k in back] == \
                [(k.p, k.q, k.normal) for k in cs]


@pytest.mark.parametrize("asm,expected", [
    (FAR_APART, set()),
    (TWO_SIDE_BY_SIDE, {("a", "b")}),
    (CORNER_TOUCH, {("a", "b")}),  # vertex to vertex: no contact, but the parts meet
    (FRAMED, {("core", "frame")}),
    (make("loose", [{"id": "frame", "polygon": square(0, 0, 10), "holes": [square(3, 3, 4)]},
                    {"id": "core", "polygon": square(4, 4, 2)}]), set()),
    (make("point", [{"id": "a", "polygon": square(0, 0, 2)},
                    {"id": "b", "polygon": [[1, 2], [3, 4], [0, 4]]}]), {("a", "b")}),
])
def test_meeting_pairs(asm, expected):
    """Closed polygons that share a point, vertex-vertex included (the contact table leaves that
    out), exactly: a hair's gap is apart."""
    assert meeting_pairs(asm) == expected


def test_meeting_pairs_are_exact_at_a_tiny_gap():
    gap = make("gap", [{"id": "a", "polygon": square(0, 0)},
                       {"id": "b", "polygon": [[Decimal("1.000001"), 0], [2, 0], [2, 1],
                                               [Decimal("1.000001"), 1]]}])
    assert meeting_pairs(gap) == set()
    assert meeting_pairs(_moved(TWO_SIDE_BY_SIDE, 7, -3, 5)) == {("a", "b")}


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10 ** 6), st.integers(0, 2))
def test_meeting_pairs_agree_with_shapely(seed, kind):
    """Every pair of the contact table meets, and shapely's closed-set test agrees on the rest."""
    asm = _sample(seed, kind)
    polys = {p.id: Polygon(p.float_outer(), p.float_holes()) for p in asm.parts}
    meet = meeting_pairs(asm)
    assert set(contact_table(asm)) <= meet
    for i, a in enumerate(asm.ids):
        for b in asm.ids[i + 1:]:
            lo, hi = sorted((a, b))
            assert ((lo, hi) in meet) == polys[lo].intersects(polys[hi])
