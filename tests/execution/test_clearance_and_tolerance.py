"""A step's clearance (exact) and tolerance (simulated): a wider slot gives both more."""

from __future__ import annotations

from fractions import Fraction

import pytest

from rap.execution.clearance import clearance
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
