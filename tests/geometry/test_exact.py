"""Exact kernel: scaling, angle order on the circle, arcs."""

from __future__ import annotations

import math
from fractions import Fraction

from hypothesis import assume, given
from hypothesis import strategies as st

from rap.geometry.exact import (angle_key, arc_interior_vector, arc_middle_unit, bounding_box,
                                compare_angle, exact_direction, in_open_arc, primitive,
                                same_direction, scale_factor, to_integers)

from .fixtures import DECIMALS, GRID2

coord = st.integers(-60, 60)
vec = st.tuples(coord, coord).filter(lambda v: v != (0, 0))


def _angle(v):
    a = math.atan2(v[1], v[0])
    return a + 2 * math.pi if a < 0 else a


def test_scaling_is_exact():
    assert scale_factor(GRID2) == 1
    ia = to_integers(DECIMALS)
    assert ia.scale == 10
    assert ia.parts[1].outer[0] == (1, 0) and ia.parts[2].outer[0] == (3, 0)


@given(vec, vec)
def test_compare_angle_matches_atan2(u, v):
    c = compare_angle(u, v)
    if same_direction(u, v):
        assert c == 0 and angle_key(u) == angle_key(v)
    else:
        assert c == (-1 if _angle(u) < _angle(v) else 1)
        assert (angle_key(u) < angle_key(v)) == (c < 0)


def test_angle_zero_is_first():
    dirs = [(0, -1), (1, -1), (-1, 0), (1, 0), (0, 1), (5, 1)]
    assert sorted(dirs, key=angle_key) == [(1, 0), (5, 1), (0, 1), (-1, 0), (0, -1), (1, -1)]


@given(vec, vec, vec)
def test_in_open_arc_matches_angles(s, e, d):
    assume(not same_direction(d, s) and not same_direction(d, e))
    span = (_angle(e) - _angle(s)) % (2 * math.pi) or 2 * math.pi
    off = (_angle(d) - _angle(s)) % (2 * math.pi)
    assert in_open_arc(d, s, e) == (off < span)


@given(vec, vec)
def test_interior_vector_is_strictly_inside(s, e):
    d = arc_interior_vector(s, e)
    assert in_open_arc(d, s, e)
    m = arc_middle_unit(s, e)
    assert in_open_arc(exact_direction(m), s, e) or abs(
        (_angle(e) - _angle(s)) % (2 * math.pi)) < 1e-9


def test_special_arcs():
    assert arc_interior_vector((1, 0), (-1, 0)) == (0, 1)  # exactly 180 degrees
    assert arc_interior_vector((1, 0), (2, 0)) == (-1, 0)  # circle minus (1, 0)
    assert arc_interior_vector(None, None) == (1, 0)  # full circle
    assert in_open_arc((0, -1), (1, 1), (1, -1))  # > 180 degrees
    assert not in_open_arc((1, 0), (1, 1), (1, -1))
    assert primitive((4, -6)) == (2, -3)
    assert exact_direction((Fraction(1, 3), Fraction(1, 2))) == (2, 3)


@given(st.lists(st.tuples(st.integers(-10**30, 10**30), st.integers(-10**30, 10**30)), min_size=1,
                max_size=20))
def test_bounding_box_holds_every_point_and_touches_the_extremes_exactly(points):
    x0, y0, x1, y1 = bounding_box(points)
    assert all(x0 <= x <= x1 and y0 <= y <= y1 for x, y in points)
    assert {x0, x1} <= {x for x, _ in points} and {y0, y1} <= {y for _, y in points}


def test_bounding_box_keeps_fractions_exact():
    box = bounding_box([(Fraction(1, 3), Fraction(-2, 7)), (Fraction(1, 2), Fraction(5, 3))])
    assert box == (Fraction(1, 3), Fraction(-2, 7), Fraction(1, 2), Fraction(5, 3))
    assert all(isinstance(v, Fraction) for v in box)
