"""The filtered batch predicates agree with the exact integer ones, degenerate cases included."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.geometry import validation
from rap.geometry.batch import box_pairs, crossing_signs
from rap.geometry.validation import ring_is_simple, segments_intersect

BIG = 2 ** 51 - 1


def _pairwise(ring) -> bool:
    """``ring_is_simple`` with the batch path switched off."""
    old = validation._BATCH_MIN
    validation._BATCH_MIN = 10 ** 9
    try:
        return ring_is_simple(ring)
    finally:
        validation._BATCH_MIN = old


coordinates = st.one_of(st.integers(-3, 3), st.integers(-BIG, BIG))
points = st.tuples(coordinates, coordinates)


@settings(max_examples=400, deadline=None, derandomize=True)
@given(st.lists(st.tuples(points, points, points, points), min_size=1, max_size=30),
       st.integers(0, BIG // 4))
def test_crossing_signs_never_contradict_the_exact_test(segments, shift):
    """Certain answers of the filter equal the exact test's, also for near-collinear segments far
    from the origin (a shift of up to 2^49 keeps every difference exact)."""
    shifted = [tuple((x + shift if abs(x + shift) < 2 ** 51 else x, y) for x, y in seg)
               for seg in segments]
    rows = np.array([[c for p in seg for c in p] for seg in shifted], dtype=np.float64)
    a, b, c, d = rows[:, 0:2], rows[:, 2:4], rows[:, 4:6], rows[:, 6:8]
    crossing, undecided = crossing_signs(a, b, c, d)
    for k, (p, q, r, s) in enumerate(shifted):
        exact = segments_intersect(p, q, r, s)
        if crossing[k]:
            assert exact
        elif not undecided[k]:
            assert not exact


def test_box_pairs_lists_each_meeting_pair_once():
    rng = np.random.default_rng(3)
    lo = rng.integers(0, 50, size=(300, 2))
    boxes = np.column_stack([lo, lo + rng.integers(0, 8, size=(300, 2))]).astype(float)
    got = set()
    for i, j in box_pairs(boxes):
        for a, b in zip(i.tolist(), j.tolist()):
            key = (min(a, b), max(a, b))
            assert key not in got and a != b
            got.add(key)
    want = {(a, b) for a in range(300) for b in range(a + 1, 300)
            if boxes[a, 0] <= boxes[b, 2] and boxes[b, 0] <= boxes[a, 2]
            and boxes[a, 1] <= boxes[b, 3] and boxes[b, 1] <= boxes[a, 3]}
    assert got == want


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.integers(0, 6), st.integers(0, 6)), min_size=49, max_size=49,
                unique=True) | st.lists(points, min_size=49, max_size=80, unique=True))
def test_the_batch_ring_check_equals_the_pairwise_one(ring):
    """On a 7x7 grid almost every ring touches itself at a vertex or along a collinear edge: the
    cases the filter hands to the exact test."""
    assert ring_is_simple(ring) == _pairwise(ring)


def _star(q: int, outer: int, inner: int):
    return [(round((outer if k % 2 == 0 else inner) * math.cos(2 * math.pi * k / q)),
             round((outer if k % 2 == 0 else inner) * math.sin(2 * math.pi * k / q)))
            for k in range(q)]


def test_large_rings_simple_and_not():
    star = _star(2000, 10 ** 15, 10 ** 12)
    assert ring_is_simple(star) and _pairwise(star)
    touching = star[:1000] + [star[0]] + star[1000:]  # revisits vertex 0: self-touching
    assert not ring_is_simple(touching)
    comb = [(0, 0)] + [(x, y) for k in range(200) for x, y in ((2 * k + 1, 10), (2 * k + 2, 0))]
    comb += [(401, -1), (0, -1)]
    assert ring_is_simple(comb)
    pinched = comb[:100] + [(comb[100][0], 0)] + comb[101:]  # a tooth's tip down on the base line
    assert ring_is_simple(pinched) == _pairwise(pinched)
