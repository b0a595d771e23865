"""Exact triangulation (shapely CDT mapped back, ear clipping fallback) and convex pieces."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rap.geometry.exact import orient
from rap.geometry.triangulate import (convex_pieces, ear_clip, is_convex_ring, ring_area2,
                                      triangulate)
from rap.geometry.validation import ring_is_simple

SHAPES = {
    "square": ([(0, 0), (2, 0), (2, 2), (0, 2)], []),
    "L": ([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)], []),
    "comb": ([(0, 0), (7, 0), (7, 3), (6, 3), (6, 1), (5, 1), (5, 3), (4, 3), (4, 1), (3, 1),
              (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)], []),
    "frame": ([(0, 0), (10, 0), (10, 10), (0, 10)], [[(3, 3), (3, 7), (7, 7), (7, 3)]]),
    "two holes": ([(0, 0), (12, 0), (12, 6), (0, 6)],
                  [[(1, 1), (1, 5), (5, 5), (5, 1)], [(7, 1), (7, 5), (11, 5), (11, 1)]]),
    "collinear": ([(0, 0), (1, 0), (2, 0), (2, 2), (1, 1), (0, 2)], []),
}


def _check(tris, outer, holes):
    verts = set(outer) | {v for h in holes for v in h}
    assert all(orient(*t) > 0 for t in tris)
    assert all(v in verts for t in tris for v in t)
    assert sum(orient(*t) for t in tris) == ring_area2(outer) + sum(ring_area2(h) for h in holes)


@pytest.mark.parametrize("name", SHAPES)
def test_triangulate_and_ear_clip(name):
    outer, holes = SHAPES[name]
    _check(triangulate(outer, holes), outer, holes)
    _check(ear_clip(outer, holes), outer, holes)


@pytest.mark.parametrize("name", SHAPES)
def test_convex_pieces(name):
    outer, holes = SHAPES[name]
    pieces = convex_pieces(outer, holes)
    assert all(is_convex_ring(p) and ring_area2(p) > 0 for p in pieces)
    assert sum(ring_area2(p) for p in pieces) == ring_area2(outer) + sum(ring_area2(h) for h in holes)
    if name == "square":
        assert pieces == [tuple(outer)]
    if name == "L":
        assert len(pieces) == 2


def test_huge_coordinates_fall_back_exactly():
    big = 10 ** 30
    outer = [(0, 0), (3 * big, 0), (3 * big, big), (big + 1, big), (big + 1, 3 * big), (0, 3 * big)]
    _check(triangulate(outer), outer, [])


@st.composite
def star_polygon(draw):
    n = draw(st.integers(3, 12))
    pts = set()
    for k in range(n):
        r = draw(st.integers(2, 40))
        a = 2 * math.pi * (k + draw(st.floats(0.1, 0.9))) / n
        pts.add((round(r * math.cos(a)), round(r * math.sin(a))))
    ring = sorted(pts, key=lambda p: math.atan2(p[1], p[0]))
    assume(len(ring) >= 3 and ring_area2(ring) > 0 and ring_is_simple(ring))
    return ring


@settings(max_examples=60, deadline=None)
@given(star_polygon())
def test_random_polygons(ring):
    _check(triangulate(ring), ring, [])
    _check(ear_clip(ring), ring, [])
    pieces = convex_pieces(ring)
    assert sum(ring_area2(p) for p in pieces) == ring_area2(ring)
