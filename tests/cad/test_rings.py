"""rap.cad.rings on plain drawn paths (no files): shared boundaries get the same vertices."""

from __future__ import annotations

import math

from rap.cad.drawing import DrawnPath

from .fixtures import arc, polygon, rings_of, src


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
