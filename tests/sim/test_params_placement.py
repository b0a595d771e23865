"""SimParams serialisation, placement of the start pose, convex pieces of parts."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.operation import Operation, unit
from rap.sim import shapes
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.sim.placement import frame_axes, placement, start_offset

from .fixtures import ASSEMBLIES, CASES

#: the default parameters' fingerprint: part of every committed label key (datasets/corpus)
DEFAULT_FINGERPRINT = "14049154e3460a57"


def test_params_round_trip_and_fingerprint():
    p = SimParams()
    d = p.to_dict()
    assert json.loads(json.dumps(d)) == d
    assert SimParams.from_dict(d) == p
    assert p.fingerprint() == SimParams().fingerprint()
    assert len(p.fingerprint()) == 16
    assert p.with_(eta=3.0).fingerprint() != p.fingerprint()
    # retiring decided trials can move an outcome (contact order): off is another label space,
    # while the default's fingerprint (every committed label key) stays what it always was
    assert p.with_(retire=False).fingerprint() != p.fingerprint()
    assert p.fingerprint() == DEFAULT_FINGERPRINT
    assert p.trials == 100 and p.eta == 9.0
    with pytest.raises(ValueError):
        SimParams.from_dict({**d, "bogus": 1})
    with pytest.raises(ValueError):
        SimParams(trials=0)


def _check_outside(a, o, gap):
    pl = placement(a, o, gap)
    d, n = frame_axes(o.direction)
    fixed_u = [float(x) * d[0] + float(y) * d[1] for i in o.fixed for x, y in a.part(i).outer]
    moving_u = [(float(x) + pl.start_offset[0]) * d[0] + (float(y) + pl.start_offset[1]) * d[1]
                for i in o.moving for x, y in a.part(i).outer]
    # completely before the fixed box along the motion, at least the gap away
    assert max(moving_u) <= min(fixed_u) - gap * pl.extent + 1e-9
    assert pl.travel >= gap * pl.extent - 1e-12
    assert math.isclose(math.hypot(*pl.start_offset), pl.travel)


@pytest.mark.parametrize("name", sorted(CASES))
def test_start_is_outside_the_fixed_box_along_the_motion(name):
    a, o = CASES[name]
    _check_outside(a, o, DEFAULT_PARAMS.start_gap)
    assert start_offset(a, o) == placement(a, o, DEFAULT_PARAMS.start_gap).start_offset


@settings(max_examples=40, deadline=None)
@given(st.integers(-20, 20), st.integers(-20, 20), st.sampled_from(sorted(ASSEMBLIES)),
       st.floats(0.0, 0.5))
def test_start_outside_for_any_direction(dx, dy, name, gap):
    if dx == 0 and dy == 0:
        return
    a = ASSEMBLIES[name]
    moving = frozenset(a.ids[-1:])
    o = Operation(moving, frozenset(a.ids) - moving, unit(dx, dy))
    _check_outside(a, o, gap)


def _area2(poly):
    return sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]))


@pytest.mark.parametrize("name", sorted(ASSEMBLIES))
def test_convex_pieces_cover_each_part_exactly(name):
    for part in ASSEMBLIES[name].parts:
        for pieces in (shapes.convex_pieces(part), shapes._fallback_pieces(part)):
            assert sum(_area2(list(pc)) for pc in pieces) == 2 * part.area()
            for pc in pieces:
                assert shapes._is_convex(list(pc))
                assert all(isinstance(v, Fraction) for p in pc for v in p)
