"""rap.cad.parts on plain drawn paths (no files): interior points, nesting, part grouping."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.cad.drawing import Problem
from rap.cad.parts import group_parts, interior_point, nest
from rap.geometry.validation import point_in_ring

from .fixtures import polygon, rings_of


def test_interior_point_is_strictly_inside():
    # a U: the lowest-leftmost corner's triangle holds another vertex
    u = [(0, 0), (30, 0), (30, 30), (20, 30), (20, 5), (10, 5), (10, 30), (0, 30)]
    assert point_in_ring(interior_point(u), u) == 1
    assert point_in_ring(interior_point(u[::-1]), u) == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)), min_size=3, max_size=12,
                unique=True))
def test_interior_point_of_star_shaped_rings(points):
    """Points sorted by angle about their centroid make a simple (star-shaped) ring."""
    from rap.geometry.validation import ring_is_simple

    cx = sum(p[0] for p in points) / len(points)
    cy = sum(p[1] for p in points) / len(points)
    ring = sorted(points, key=lambda p: (math.atan2(p[1] - cy, p[0] - cx), p))
    from rap.assembly import signed_area2

    if signed_area2(ring) == 0 or not ring_is_simple(ring):
        return
    assert point_in_ring(interior_point(ring), ring) == 1


def test_nesting_makes_holes_and_parts_in_holes():
    plate = polygon([(0, 0), (30, 0), (30, 30), (0, 30)], "plate", 0, "P")
    hole = polygon([(10, 10), (20, 10), (20, 20), (10, 20)], "hole", 1, "P")
    peg = polygon([(10, 10), (20, 10), (20, 20), (10, 20)], "peg", 2, "Q")
    rings, _ = rings_of([plate, hole, peg])
    assert [len(h) for h in nest(rings)] == [0, 1, 2]
    parts = group_parts(rings, "loop")
    assert [(p.id, len(p.holes)) for p in parts] == [("P", 1), ("Q", 0)]
    assert [(p.id, len(p.holes)) for p in group_parts(rings, "layer")] == [("P", 1), ("Q", 0)]


def test_a_layer_with_two_outlines_is_not_one_part():
    a = polygon([(0, 0), (1, 0), (1, 1), (0, 1)], "a", 0, "L")
    b = polygon([(2, 0), (3, 0), (3, 1), (2, 1)], "b", 1, "L")
    rings, _ = rings_of([a, b])
    with pytest.raises(Problem, match=r"layer 'L' has 2 separate outlines"):
        group_parts(rings, "layer")
    assert [p.id for p in group_parts(rings, "loop")] == ["L:a", "L:b"]
