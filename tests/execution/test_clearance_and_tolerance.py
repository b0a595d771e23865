"""A step's clearance (exact) and tolerance (simulated): a wider slot gives both more."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.execution.clearance import clearance, free_travel, pair_travel
from rap.execution.tolerance import tolerance
from rap.operation import Operation
from rap.sim.params import DEFAULT_PARAMS

from tests.execution.cases import slot


@pytest.mark.parametrize("gap", [0, Fraction(1, 4), Fraction(1, 3), 1, 2])
def test_clearance_is_the_gap_on_either_side(gap):
    asm, op = slot(gap)
    assert clearance(asm, op) == float(gap)


def test_an_oblique_insertion_blocked_across_has_no_clearance_and_a_free_part_none():
    asm, op = slot(1)
    assert clearance(asm, Operation(op.moving, op.fixed, (0.6, -0.8))) == 0.0
    from rap.assembly import Assembly, Part

    apart = Assembly("apart", (Part("a", ((0, 0), (1, 0), (1, 1), (0, 1))),
                               Part("b", ((0, 1), (1, 1), (1, 2), (0, 2)))))
    assert clearance(apart, Operation(frozenset({"b"}), frozenset({"a"}), (0.0, -1.0))) is None


def test_a_wider_clearance_gives_a_larger_tolerance():
    tight = tolerance(*slot(Fraction(1, 4)), DEFAULT_PARAMS, 1.0, 0, "slot")
    wide = tolerance(*slot(Fraction(1, 2)), DEFAULT_PARAMS, 1.0, 0, "slot")
    assert 0 < tight < wide
    again = tolerance(*slot(Fraction(1, 4)), DEFAULT_PARAMS, 1.0, 0, "slot")
    assert again == tight  # seeded


_square = st.tuples(st.integers(-30, 30), st.integers(-30, 30), st.integers(1, 6)).map(
    lambda t: ((t[0], t[1]), (t[0] + t[2], t[1]), (t[0] + t[2], t[1] + t[2]), (t[0], t[1] + t[2])))


@settings(max_examples=150, deadline=None)
@given(st.lists(_square, min_size=1, max_size=3), st.lists(_square, min_size=1, max_size=8),
       st.tuples(st.integers(-5, 5), st.integers(-5, 5)).filter(lambda u: u != (0, 0)))
def test_the_pruned_travel_is_the_least_entry_over_every_piece_pair(moving, fixed, u):
    """free_travel skips pieces outside the strip and stops past the best: the same answer as
    trying every pair (squares may overlap here: only the least entry is compared)."""
    entries = [pair_travel(a, b, u) for a in moving for b in fixed]
    entries = [t for t in entries if t is not None]
    assert free_travel(moving, fixed, u) == (min(entries) if entries else None)
