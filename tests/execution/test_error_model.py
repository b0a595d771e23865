"""The cell's error model: bounds, draws in the insertion's frame, the budget."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.execution.error_model import DEFAULT_ERRORS, ErrorModel


def test_draws_stay_within_their_bounds_across_and_along_the_insertion():
    m = ErrorModel(grasp_across_mm=1.0, grasp_along_mm=0.0, grasp_angle_deg=2.0,
                   repeatability_mm=0.0)
    rng = np.random.default_rng(0)
    draws = [m.offsets(rng, (0.0, -1.0), 2.0) for _ in range(500)]
    assert all(dy == 0.0 and abs(dx) <= 0.5 for dx, dy, _ in draws)  # across a vertical insertion
    assert max(abs(dx) for dx, _, _ in draws) > 0.45
    assert all(abs(a) <= math.radians(2.0) for _, _, a in draws)


def test_zero_draws_nothing_yet_consumes_the_same_numbers():
    a, b = np.random.default_rng(1), np.random.default_rng(1)
    assert ErrorModel.zero().offsets(a, (1.0, 0.0), 1.0) == (0.0, 0.0, 0.0)
    DEFAULT_ERRORS.offsets(b, (1.0, 0.0), 1.0)
    assert a.random() == b.random()


def test_the_budget_and_bad_values():
    assert DEFAULT_ERRORS.budget_across_mm == pytest.approx(0.6)
    with pytest.raises(ValueError, match="repeatability_mm"):
        ErrorModel(repeatability_mm=-1.0)


def test_the_cell_names_the_controller_and_a_stiff_arm_rolls_out_without_force_noise():
    from rap.execution.rollout import RolloutPlan, run_chunk
    from rap.robot.cell import cell_from_toml
    from rap.sim.params import DEFAULT_PARAMS

    from tests.execution.cases import wall_prefix

    stiff = cell_from_toml("[errors]\nforce_noise = false\n").error_model()
    assert not stiff.force_noise and stiff.repeatability_mm == pytest.approx(0.1)
    asm, steps = wall_prefix(3)
    exact = ErrorModel(0.0, 0.0, 0.0, 0.0, force_noise=False)  # deterministic: no error at all
    out = run_chunk(asm, RolloutPlan(steps, DEFAULT_PARAMS, exact, 2.0), 0, 0, 10)
    assert out.failed_at == (-1,) * 10
