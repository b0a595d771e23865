"""rap.geometry.cones: cone edges inside the exact cone, exact arc intersections, middles.

Membership is checked against independent exact predicates written here: a direction lies within
30, 45 or 60 degrees of an axis exactly when ``dot > 0`` and ``cross^2 <= tan^2 * dot^2`` (tan^2 =
1/3, 1, 3: integers), within 90 when ``dot >= 0``; CCW order by the half-plane and the sign of a
cross product.
"""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.geometry.cones import (FULL, Arc, arc_middle, choose_direction, cone_arc, intersect,
                                partition_arc)
from rap.geometry.partitions import Partition

TAN2 = {30: Fraction(1, 3), 45: Fraction(1), 60: Fraction(3)}


def within(d, axis, deg) -> bool:
    """Is the angle between d and axis at most deg (30, 45, 60, 90, 120, 135, 150)? Exact."""
    dot = d[0] * axis[0] + d[1] * axis[1]
    cross = axis[0] * d[1] - axis[1] * d[0]
    if deg == 90:
        return dot >= 0
    if deg > 90:  # at least 180 - deg away from -axis
        return not (-dot > 0 and cross * cross < TAN2[180 - deg] * dot * dot)
    return dot > 0 and cross * cross <= TAN2[deg] * dot * dot


def angle_deg(u, v) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, (u[0] * v[0] + u[1] * v[1])
                                               / math.hypot(*u) / math.hypot(*v)))))


AXES = [(0, -1), (1, 0), (3, 4), (-2, 1), (Fraction(1, 2), Fraction(-3, 7))]


@pytest.mark.parametrize("deg", [30, 45, 60, 120, 135, 150])
@pytest.mark.parametrize("axis", AXES)
def test_cone_edges_lie_inside_the_exact_cone_and_close_to_its_edges(axis, deg):
    a = cone_arc(axis, deg)
    ax = (float(axis[0]), float(axis[1]))
    for edge in (a.start, a.end):
        assert within(edge, (Fraction(axis[0]), Fraction(axis[1])), deg)
        assert deg - 1e-6 < angle_deg(edge, ax) <= deg
    assert a.contains(_int(axis)) and a.start_closed and a.end_closed
    assert not a.contains(_int((-axis[0], -axis[1])))


def _int(v):
    f = (Fraction(v[0]), Fraction(v[1]))
    den = math.lcm(f[0].denominator, f[1].denominator)
    return (int(f[0] * den), int(f[1] * den))


def test_exact_special_angles():
    assert cone_arc((0, -1), 180) == FULL
    point = cone_arc((0, -2), 0)
    assert point.is_point and point.contains((0, -5)) and not point.contains((1, -1000))
    half = cone_arc((0, -1), 90)
    assert half.contains((1, 0)) and half.contains((-1, 0)) and half.contains((1, -1))
    assert not half.contains((1000000, 1))
    with pytest.raises(ValueError):
        cone_arc((0, 0), 30)
    with pytest.raises(ValueError):
        cone_arc((0, 1), 181)


def test_known_intersections():
    down = cone_arc((0, -1), 90)   # closed lower half-plane
    right = cone_arc((1, 0), 90)   # closed right half-plane
    (q,) = intersect(down, [right])
    assert (q.start, q.end, q.start_closed, q.end_closed) == ((0, -1), (1, 0), True, True)
    assert intersect(cone_arc((0, 1), 30), [cone_arc((0, -1), 30)]) == []
    # two cones over 180 degrees meet in two pieces, around (0, 1) and (0, -1)
    pieces = intersect(cone_arc((1, 0), 100), [cone_arc((-1, 0), 100)])
    assert len(pieces) == 2 and pieces[0].contains((0, 1)) and pieces[1].contains((0, -1))
    # a union of cones: the range (0, 90) degrees open meets two thin cones
    rng = Arc((1, 0), (0, 1), False, False)
    got = intersect(rng, [cone_arc((1, 1), 30), cone_arc((1, 0), 30)])
    assert len(got) == 1 and not got[0].start_closed and got[0].start == (1, 0)
    # the circle minus one direction, and a single direction
    minus = Arc((1, 0), (1, 0), False, False)
    assert intersect(minus, [FULL]) == [minus]
    assert intersect(Arc((0, -1), (0, -1)), [down]) == [Arc((0, -1), (0, -1))]
    assert intersect(Arc((0, 1), (0, 1)), [down]) == []


def test_partition_arc_reads_the_ranges_bounds():
    p = Partition(frozenset("a"), frozenset("b"), (1, 0), (0, 2), (0.7, 0.7), (1, 1), "range",
                  True, False)
    a = partition_arc(p)
    assert a == Arc((1, 0), (0, 1), True, False)
    v = Partition(frozenset("a"), frozenset("b"), (0, 1), (0, 1), (0.0, 1.0), (0, 1), "vertex",
                  True, True)
    assert partition_arc(v).is_point
    c = Partition(frozenset("a"), frozenset("b"), (1, 0), (1, 0), (0.0, 1.0), (0, 1), "circle",
                  True, True)
    assert partition_arc(c) == FULL


def test_choose_direction_takes_the_middle_of_the_piece_holding_the_axis():
    rng = Arc((1, 0), (-1, 0), False, False)  # the open upper half-plane
    d, u = choose_direction(rng, [cone_arc((0, 1), 45)], prefer=[(0, 1)])
    assert d == (0, 1) and u == pytest.approx((0.0, 1.0))
    # the cone pokes half out of the range: the middle of what is left
    d, u = choose_direction(rng, [cone_arc((1, 0), 60)], prefer=[(1, 0)])
    assert within(d, (1, 0), 60) and d[1] > 0
    assert angle_deg(d, (1, 0)) == pytest.approx(30.0, abs=1e-6)
    assert choose_direction(rng, [cone_arc((0, -1), 30)], prefer=[(0, -1)]) is None


DIRS = st.tuples(st.integers(-6, 6), st.integers(-6, 6)).filter(lambda v: v != (0, 0))


def _ccw_key(d):
    """Exact CCW angle order: half-plane, then a cross product against the half's first ray."""
    upper = d[1] > 0 or (d[1] == 0 and d[0] > 0)
    return (0 if upper else 1, Fraction(-d[0], abs(d[0]) + abs(d[1])) if upper
            else Fraction(d[0], abs(d[0]) + abs(d[1])))


def _between(d, s, e, s_closed, e_closed) -> bool:
    """d in the arc from s CCW to e (independent of the module: angle keys modulo the circle)."""
    ks, ke, kd = _ccw_key(s), _ccw_key(e), _ccw_key(d)
    if kd == ks:
        return s_closed
    if kd == ke:
        return e_closed
    if ks < ke:
        return ks < kd < ke
    return kd > ks or kd < ke


@settings(max_examples=150, deadline=None)
@given(s=DIRS, e=DIRS, t=DIRS, f=DIRS, probes=st.lists(DIRS, min_size=1, max_size=12),
       flags=st.tuples(st.booleans(), st.booleans(), st.booleans(), st.booleans()))
def test_intersection_agrees_with_an_independent_membership_test(s, e, t, f, probes, flags):
    if s[0] * e[1] == s[1] * e[0] and s[0] * e[0] + s[1] * e[1] > 0:
        return  # same direction: not an ordinary arc
    if t[0] * f[1] == t[1] * f[0] and t[0] * f[0] + t[1] * f[1] > 0:
        return
    from rap.geometry.exact import primitive

    a = Arc(primitive(s), primitive(e), flags[0], flags[1])
    b = Arc(primitive(t), primitive(f), flags[2], flags[3])
    pieces = intersect(a, [b])
    for d in probes + [s, e, t, f]:
        want = _between(d, s, e, *flags[:2]) and _between(d, t, f, *flags[2:])
        assert any(p.contains(d) for p in pieces) == want
    for p in pieces:  # each piece's middle lies in both arcs
        m, u = arc_middle(p)
        assert _between(m, s, e, *flags[:2]) and _between(m, t, f, *flags[2:])
        assert math.hypot(*u) == pytest.approx(1.0)
