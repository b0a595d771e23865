"""The settling simulation (rap.sim.settling): units, friction and determinism checked against
closed-form motion (free fall, sliding down a slope)."""

from __future__ import annotations

import math

import pytest

from rap.sim.settling import DEFAULT_SETTLING, settle
from tests.sim.cells import SLOPE, STACK, WALL, DOWN


def _world_scale(asm) -> float:
    x0, y0, x1, y1 = asm.bounds()
    return DEFAULT_SETTLING.world_size / max(x1 - x0, y1 - y0)


def _fall(accel: float, seconds: float) -> float:
    """Distance covered from rest in whole steps by Chipmunk's integrator, which moves the
    bodies with their velocities before it adds the step's acceleration."""
    dt = DEFAULT_SETTLING.dt_s
    n = round(seconds / dt)
    return accel * dt * dt * n * (n - 1) / 2


def test_a_part_touching_nothing_falls_freely():
    got = settle(STACK, ["plate", "block2"], "plate", DOWN, seconds=0.1)  # before it lands
    want = _fall(DEFAULT_SETTLING.gravity_accel, 0.1) / _world_scale(STACK)
    assert got.moved == ("block2",) and not got.stable
    assert got.max_displacement == pytest.approx(want, rel=1e-6)


def test_block_slides_down_the_slope_at_the_coulomb_rate():
    # slope angle: tan = 1/2; a = g (sin - mu cos) along it (the shapes' sqrt(mu) multiply to mu)
    mu, seconds = 0.2, 0.25
    s, c = 1 / math.sqrt(5), 2 / math.sqrt(5)
    want = _fall(DEFAULT_SETTLING.gravity_accel * (s - mu * c), seconds) / _world_scale(SLOPE)
    got = settle(SLOPE, SLOPE.ids, "wedge", DOWN, seconds=seconds, friction=mu)
    assert got.moved == ("block",)
    assert got.max_displacement == pytest.approx(want, rel=0.05)
    held = settle(SLOPE, SLOPE.ids, "wedge", DOWN, friction=0.6)
    assert held.stable and held.max_displacement < 0.05  # a creep; "moved" is 0.24 (2% of 12)


def test_stable_stack_barely_moves_and_runs_are_identical():
    first = settle(WALL, WALL.ids, "plate", DOWN)
    assert first.stable and first.moved == ()
    assert first.max_displacement < DEFAULT_SETTLING.moved_fraction * 10  # bricks are 20 x 10
    assert settle(WALL, list(reversed(WALL.ids)), "plate", DOWN) == first
    assert dict(first.displacements).keys() == set(WALL.ids) - {"plate"}


def test_base_alone_and_bad_arguments():
    assert settle(STACK, ["plate"], "plate", DOWN).stable
    with pytest.raises(ValueError, match="base"):
        settle(STACK, ["block1"], "plate", DOWN)
    with pytest.raises(ValueError, match="gravity"):
        settle(STACK, STACK.ids, "plate", (0.0, 0.0))
    with pytest.raises(KeyError):
        settle(STACK, ["plate", "nope"], "plate", DOWN)
