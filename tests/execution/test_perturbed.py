"""rap.execution.perturbed: a perturbed-start score is seeded, an operation with its fixed parts in
place scores as without them displaced only through the grasp, and pushing the fixed parts off
their places costs a tight fit successes; the shipped rest offsets are what the module says."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rap.execution.error_model import ErrorModel
from rap.execution.perturbed import REST_OFFSETS, perturbed_successes, rest_offsets
from rap.io import load_assembly
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

ROOT = Path(__file__).resolve().parents[2]


def test_the_shipped_rest_offsets_are_fractions_of_the_tolerance_and_small_angles():
    recorded = rest_offsets()
    assert REST_OFFSETS.is_file() and recorded.shape[1] == 2 and len(recorded) > 1000
    assert (recorded[:, 0] >= 0).all() and np.quantile(recorded[:, 0], 0.5) < 1.0
    assert (np.abs(recorded[:, 1]) < np.pi).all()


def test_a_perturbed_score_is_seeded_and_displaced_parts_cost_a_tight_fit():
    asm = load_assembly(ROOT / "assemblies" / "cells" / "side-peg.json")
    params = SimParams(trials=40)
    problem = PlanningProblem(asm, params, 0)
    op = next(op for c in reachable(problem).values() for op in c if not problem.is_free(op))
    still = np.zeros((1, 2))
    far = np.array([[6.0, 0.2]])  # six tolerance radii off, turned 0.2 rad: the peg cannot enter
    seed = problem.seed(op)
    exact = perturbed_successes(asm, op, params, ErrorModel.zero(), 1.0, seed, still)
    assert exact == perturbed_successes(asm, op, params, ErrorModel.zero(), 1.0, seed, still)
    assert 0 < exact <= params.trials
    pushed = perturbed_successes(asm, op, params, ErrorModel.zero(), 1.0, seed, far)
    assert pushed < exact
