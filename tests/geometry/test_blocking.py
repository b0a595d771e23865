"""Blocking arcs: symmetry, invariance, agreement with an independent swept-area check."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import MultiPoint, Polygon

from rap.geometry.blocking import (FULL, BlockedSet, blocking_arcs, convex_hull, merge_arcs,
                                   piece_cone)
from rap.geometry.exact import primitive
from rap.geometry.triangulate import convex_pieces

from .test_triangulate import star_polygon

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
vec = st.tuples(st.integers(-50, 50), st.integers(-50, 50)).filter(lambda v: v != (0, 0))


def _bbox(ring):
    xs, ys = [p[0] for p in ring], [p[1] for p in ring]
    return min(xs), min(ys), max(xs), max(ys)


@st.composite
def separated_pair(draw):
    """Two simple integer polygons with disjoint interiors (boxes apart or just touching)."""
    a = draw(star_polygon())
    b = draw(star_polygon())
    ax0, ay0, ax1, ay1 = _bbox(a)
    bx0, by0, bx1, by1 = _bbox(b)
    side = draw(st.sampled_from(["right", "above", "left", "below"]))
    gap = draw(st.integers(0, 20))
    slide = draw(st.integers(-30, 30))
    if side == "right":
        t = (ax1 - bx0 + gap, slide)
    elif side == "left":
        t = (ax0 - bx1 - gap, slide)
    elif side == "above":
        t = (slide, ay1 - by0 + gap)
    else:
        t = (slide, ay0 - by1 - gap)
    b = [(x + t[0], y + t[1]) for x, y in b]
    return a, b


def _arcs(a, b):
    return blocking_arcs(convex_pieces(a), convex_pieces(b))


@SETTINGS
@given(separated_pair(), vec)
def test_reversal_symmetry(pair, d):
    a, b = pair
    ab, ba = _arcs(a, b), _arcs(b, a)
    assert ab.contains(d) == ba.contains((-d[0], -d[1]))
    assert ba == ab.negated()


@SETTINGS
@given(separated_pair(), st.integers(1, 7), vec, vec)
def test_scaling_and_translation_invariance(pair, k, t, d):
    a, b = pair
    base = _arcs(a, b)
    scaled = _arcs([(k * x, k * y) for x, y in a], [(k * x, k * y) for x, y in b])
    moved = _arcs([(x + t[0], y + t[1]) for x, y in a], [(x + t[0], y + t[1]) for x, y in b])
    assert scaled == base == moved
    assert base.contains(d) == moved.contains(d)


def _endpoints(bs: BlockedSet):
    return [v for arc in bs.arcs for v in arc]


def _ang_dist(u, v):
    a = abs(math.atan2(u[1], u[0]) - math.atan2(v[1], v[0])) % (2 * math.pi)
    return min(a, 2 * math.pi - a)


def swept_blocks(a, b, d, far=10_000.0) -> bool:
    """Independent float check: sweep each convex piece of a far along d; overlap with b?"""
    ux, uy = d[0] / math.hypot(*d), d[1] / math.hypot(*d)
    pb = Polygon(b)
    for piece in convex_pieces(a):
        pts = list(piece) + [(x + far * ux, y + far * uy) for x, y in piece]
        sweep = MultiPoint(pts).convex_hull
        if sweep.intersection(pb).area > 1e-6:
            return True
    return False


@SETTINGS
@given(separated_pair(), st.floats(0, 2 * math.pi, exclude_max=True))
def test_agrees_with_swept_area(pair, angle):
    a, b = pair
    d = (math.cos(angle), math.sin(angle))
    bs = _arcs(a, b)
    # only directions clearly away from every critical direction (a tolerance of the test only)
    assume(all(_ang_dist(d, e) > 1e-2 for e in _endpoints(bs)))
    exact_d = (round(d[0] * 10 ** 6), round(d[1] * 10 ** 6))
    assert bs.contains(exact_d) == swept_blocks(a, b, d)


@given(st.integers(3, 40), st.integers(-30, 30), st.integers(1, 5))
def test_far_apart_blocks_only_in_shadow_cone(dist, dy, s):
    a = [(0, 0), (s, 0), (s, s), (0, s)]
    b = [(x + dist + s, y + dy) for x, y in a]  # b is to the right of a, with a gap
    bs = _arcs(a, b)
    # b - a fills the box [dist, dist + 2s] x [dy - s, dy + s] (x > 0): its shadow cone is
    # spanned by the corners of least and greatest slope
    corners = [(x, y) for x in (dist, dist + 2 * s) for y in (dy - s, dy + s)]
    lo = primitive(min(corners, key=lambda c: c[1] / c[0]))
    hi = primitive(max(corners, key=lambda c: c[1] / c[0]))
    assert bs.arcs == ((lo, hi),)
    assert bs.contains((dist + s, dy)) and not bs.contains((-1, 0))
    assert not bs.contains(lo) and not bs.contains(hi)


def test_touching_edge_gives_half_plane():
    a = [(0, 0), (1, 0), (1, 1), (0, 1)]
    b = [(1, 0), (2, 0), (2, 1), (1, 1)]
    bs = _arcs(a, b)
    assert bs.arcs == (((0, -1), (0, 1)),)  # open half-plane x > 0: sliding up/down is free
    assert not bs.contains((0, 1)) and bs.contains((1, 5))


def test_corner_touch_gives_quarter():
    a = [(0, 0), (1, 0), (1, 1), (0, 1)]
    b = [(1, 1), (2, 1), (2, 2), (1, 2)]
    assert _arcs(a, b).arcs == (((1, 0), (0, 1)),)


def test_framed_part_is_blocked_everywhere():
    frame_pieces = convex_pieces([(0, 0), (10, 0), (10, 10), (0, 10)],
                                 [[(3, 3), (3, 7), (7, 7), (7, 3)]])
    core = [[(3, 3), (7, 3), (7, 7), (3, 7)]]
    assert blocking_arcs(core, frame_pieces) == FULL


def test_merge_arcs():
    assert merge_arcs([((1, 0), (0, 1)), ((0, 1), (-1, 0))]).arcs == (((1, 0), (0, 1)),
                                                                      ((0, 1), (-1, 0)))
    assert merge_arcs([((1, 0), (-1, 1)), ((0, 1), (-1, 0))]).arcs == (((1, 0), (-1, 0)),)
    assert merge_arcs([((1, -1), (1, 1)), ((1, 0), (0, 1))]).arcs == (((1, -1), (0, 1)),)
    # three arcs covering everything but (1, 0)
    m = merge_arcs([((1, 0), (-1, 1)), ((0, 1), (-1, -1)), ((-1, 0), (1, 0))])
    assert m.arcs == (((1, 0), (1, 0)),) and not m.contains((1, 0)) and m.contains((1, 1))
    assert merge_arcs([((1, 0), (-1, 1)), ((0, 1), (-1, -1)), ((-1, 0), (1, 1))]) == FULL



@st.composite
def pocketed_pair(draw):
    """A small square in a star polygon's box, not overlapping it: hulls that meet, parts apart."""
    b = draw(star_polygon())
    x0, y0, x1, y1 = _bbox(b)
    s = draw(st.integers(1, 8))
    x, y = draw(st.integers(x0 - s, x1)), draw(st.integers(y0 - s, y1))
    a = [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]
    assume(Polygon(a).intersection(Polygon(b)).area == 0)
    return a, b


def _every_piece_cone(a, b) -> BlockedSet:
    return merge_arcs([piece_cone(A, B) for A in convex_pieces(a) for B in convex_pieces(b)])


@SETTINGS
@given(st.one_of(separated_pair(), pocketed_pair()))
def test_the_bounded_search_is_the_union_of_every_piece_cone(pair):
    a, b = pair
    assert _arcs(a, b) == _every_piece_cone(a, b)
    assert _arcs(b, a) == _every_piece_cone(b, a)


def test_a_dovetail_is_blocked_everywhere_and_a_part_beside_it_in_one_arc():
    socket = [(0, 0), (10, 0), (10, 10), (6, 10), (7, 6), (3, 6), (4, 10), (0, 10)]
    tab = [(0, 10), (4, 10), (3, 6), (7, 6), (6, 10), (10, 10), (10, 14), (0, 14)]
    dovetail_pieces = convex_pieces(socket)
    assert blocking_arcs(convex_pieces(tab), dovetail_pieces) == _every_piece_cone(tab, socket)
    assert blocking_arcs(convex_pieces(tab), dovetail_pieces) == FULL
    far = [(20, 0), (24, 0), (24, 3), (20, 3)]
    assert _arcs(far, socket) == _every_piece_cone(far, socket)
    assert len(_arcs(far, socket).arcs) == 1


def test_convex_hull_is_ccw_without_collinear_points():
    pts = [(0, 0), (2, 0), (4, 0), (4, 4), (2, 2), (0, 4), (2, 4), (0, 2)]
    assert convex_hull(pts) == ((0, 0), (4, 0), (4, 4), (0, 4))
    assert convex_hull([(1, 1), (1, 1)]) == ((1, 1),)
