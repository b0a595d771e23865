"""rap.cad.loops, rap.cad.parts and rap.cad.snap on plain drawn paths (no files)."""

from __future__ import annotations

import math
from decimal import Decimal

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.cad.drawing import DrawnPath, Problem, Source
from rap.cad.loops import exact_rings, join_loops
from rap.cad.parts import group_parts, interior_point, nest
from rap.cad.snap import Grid
from rap.errors import InputError
from rap.geometry.validation import point_in_ring

GRID = Grid.parse("0.01")


def src(name: str, order: int = 0, layer: str = "0") -> Source:
    return Source("dxf", "LWPOLYLINE", name, layer, order)


def polygon(points, name, order=0, layer="0") -> DrawnPath:
    """A closed path of straight pieces."""
    n = len(points)
    return DrawnPath([[points[i], points[(i + 1) % n]] for i in range(n)], src(name, order, layer),
                     True)


def arc(cx, cy, r, a0, a1, n) -> list:
    return [(cx + r * math.cos(a0 + (a1 - a0) * k / n), cy + r * math.sin(a0 + (a1 - a0) * k / n))
            for k in range(n + 1)]


def rings_of(paths, grid=GRID):
    return exact_rings(join_loops(paths, grid.step_float, "mm"), grid, "mm")


@pytest.mark.parametrize("text,needle", [("1e-7", "finer"), ("0.0000015", "finer"),
                                         ("0", "positive"), ("-1", "positive"), ("abc", "number"),
                                         ("5000", "coarser")])
def test_bad_tolerances_are_refused_in_one_line(text, needle):
    with pytest.raises(InputError, match=needle) as e:
        Grid.parse(text)
    assert "\n" not in str(e.value)


def test_the_grid_is_exact():
    g = Grid.parse("0.0025")
    assert g.value(g.index(1.0)) == Decimal(1) and g.value(3) == Decimal("0.0075")
    assert Grid.parse(1e-6).step == Decimal("0.000001")


def test_one_shared_curve_flattened_differently_on_each_side_gets_one_vertex_list():
    """Side A has the arc in 25 chords, side B (drawn the other way) in 31, both within the
    tolerance of it: both get A's vertices."""
    a_arc = arc(10, 5, 5, -math.pi / 2, math.pi / 2, 25)
    b_arc = arc(10, 5, 5, math.pi / 2, -math.pi / 2, 31)
    a = DrawnPath([[(0, 0), (10, 0)], a_arc, [(10, 10), (0, 10)], [(0, 10), (0, 0)]], src("A"),
                  True)
    b = DrawnPath([[(10, 0), (20, 0)], [(20, 0), (20, 10)], [(20, 10), (10, 10)], b_arc],
                  src("B", 1), True)
    (ra, rb), gaps = rings_of([a, b])
    curve_a = [v for v in ra.vertices if v[0] > 1000]
    curve_b = [v for v in rb.vertices if 1000 < v[0] < 2000]
    assert sorted(curve_a) == sorted(curve_b) and len(curve_a) == 24  # A's 24 inner points
    assert gaps == 0


def test_ends_that_round_apart_are_merged_before_snapping():
    """0.005 -+ 1e-12 would snap to 0.00 and 0.01: merged first, they are one vertex."""
    lo, hi = 0.005 - 1e-12, 0.005 + 1e-12
    a = DrawnPath([[(lo, 0), (10, 0)], [(10, 0), (10, 10)], [(10, 10), (hi, 0)]], src("A"), True)
    ((ring,), gaps) = rings_of([a])
    assert len(ring.vertices) == 3 and gaps == 0


def test_a_t_junction_vertex_is_inserted_on_the_long_edge():
    a = polygon([(0, 0), (10, 0), (13, 9), (0, 9)], "A")
    b = polygon([(10, 0), (20, 0), (20, 9), (13, 9), (11.5, 4.5)], "B", 1)
    (ra, rb), _ = rings_of([a, b])
    assert (1150, 450) in ra.vertices  # B's vertex, now one of A's


def test_open_paths_join_within_their_layer_only():
    half1 = DrawnPath([[(0, 0), (10, 0)], [(10, 0), (10, 10)]], src("h1", 0, "L1"), False)
    half2 = DrawnPath([[(10, 10), (0, 10)], [(0, 10), (0, 0)]], src("h2", 1, "L1"), False)
    (loop,) = join_loops([half1, half2], 0.01, "mm")
    assert len(loop.pieces) == 4 and loop.source.ident == "h1"
    half2 = DrawnPath(half2.pieces, src("h2", 1, "L2"), False)
    with pytest.raises(Problem, match=r"open loop.*gap to the nearest free end.* is 14\.1421 mm"):
        join_loops([half1, half2], 0.01, "mm")


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
