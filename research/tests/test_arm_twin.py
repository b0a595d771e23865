"""research.variants.arm_twin: free placed parts under gravity and friction, a stiff cup, rollouts
that depend on their index alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from rap.execution.error_model import ErrorModel
from rap.execution.rollout import RolloutPlan
from rap.io import load_assembly
from rap.operation import Operation
from rap.robot.cell import Cell
from rap.sim.params import DEFAULT_PARAMS
from research.variants.arm_twin import ArmTwin, run_twin_chunk, twin_of

ROOT = Path(__file__).resolve().parents[2]
ARCH = load_assembly(ROOT / "assemblies" / "cells" / "arch-centring.json")


def _left_then_keystone(errors: ErrorModel) -> RolloutPlan:
    """The arch's first voussoir onto its centring, then the keystone (both straight down)."""
    steps = (Operation(frozenset({"left"}), frozenset({"centring"}), (0.0, -1.0)),
             Operation(frozenset({"keystone"}), frozenset({"centring", "left"}), (0.0, -1.0)))
    return RolloutPlan(steps, DEFAULT_PARAMS, errors, 2.0)


def test_a_voussoir_on_its_centring_stays_where_the_statics_say_it_can():
    """rap.sim.statics: the left voussoir has no equilibrium on the centring at friction 0.09 and
    one at 0.3. Placed exactly, it slides off in the twin at 0.09 (a free body the shipped
    rollouts would hold static) and stays at 0.3."""
    plan = _left_then_keystone(ErrorModel.zero())
    slides = run_twin_chunk(ARCH, plan, ArmTwin("centring", (0.0, -1.0), friction=0.09), 0, 0, 2)
    stays = run_twin_chunk(ARCH, plan, ArmTwin("centring", (0.0, -1.0), friction=0.3), 0, 0, 2)
    assert slides.failed_at == (0, 0)
    assert stays.failed_at == (-1, -1)


def test_a_rollout_depends_on_its_index_not_on_its_chunk():
    errors = ErrorModel(1.0, 1.0, 0.0, 0.1, force_noise=True)
    plan = _left_then_keystone(errors)
    twin = ArmTwin("centring", (0.0, -1.0))
    whole = run_twin_chunk(ARCH, plan, twin, 7, 0, 3).failed_at
    alone = tuple(run_twin_chunk(ARCH, plan, twin, 7, i, 1).failed_at[0] for i in range(3))
    assert whole == alone
    assert run_twin_chunk(ARCH, plan, twin, 7, 0, 3).failed_at == whole


def test_the_twin_takes_the_plans_fixture_and_gravity_and_the_cells_constants():
    twin = twin_of({"constraints": {"base": "plate", "gravity": "0,-1"}}, Cell())
    assert (twin.fixture, twin.gravity) == ("plate", (0.0, -1.0))
    assert twin.thickness_mm == pytest.approx(20.0) and twin.cup_radius_mm == pytest.approx(6.0)
    lying = twin_of({"constraints": {"base": "tray"}}, Cell())
    assert lying.gravity is None


def test_a_step_that_does_not_move_into_the_fixtures_subassembly_is_refused():
    plan = RolloutPlan((Operation(frozenset({"keystone"}), frozenset({"left"}), (0.0, -1.0)),),
                       DEFAULT_PARAMS, ErrorModel.zero(), 2.0)
    with pytest.raises(ValueError, match="one-arm plans"):
        run_twin_chunk(ARCH, plan, ArmTwin("centring", (0.0, -1.0)), 0, 0, 1)
