"""research.perturbed_scorer: the features of an operation, and the cross-validation that compares
the trees with the exact-start score as predictors of the perturbed success rate."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rap.io import load_assembly
from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams
from research.perturbed_scorer import _non_free, cross_validate, features

ROOT = Path(__file__).resolve().parents[2]


def test_features_are_the_descriptors_and_the_expected_score_of_each_operation():
    problem = PlanningProblem(load_assembly(ROOT / "assemblies" / "cells" / "arch.json"),
                              SimParams(), 0)
    ops = _non_free(problem, reachable(problem))
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    x = features(problem, ops, model)
    assert x.shape == (len(ops), 13) and len(ops) > 0
    assert np.all((x[:, -1] >= 0) & (x[:, -1] <= 1))
    assert np.allclose(x[:, -1], model.expected_score(problem, ops))


def test_cross_validation_scores_trees_and_the_exact_score_on_held_out_assemblies():
    """Rows whose perturbed rate is the exact score halved where the first descriptor is large:
    the trees learn it (held out by assembly), the exact score alone cannot."""
    rng = np.random.default_rng(0)
    n = 3000
    x = rng.uniform(0, 1, (n, 13))
    rate = np.where(x[:, 0] > 0.5, x[:, -1] / 2, x[:, -1])
    trials = np.full(n, 100.0)
    successes = rng.binomial(100, rate).astype(float)
    group = np.arange(n) // 100  # 30 "assemblies"
    cv = cross_validate(x, successes, trials, group)
    assert cv["rows"] == n and cv["assemblies"] == 30
    assert cv["mae_trees"] < 0.08 < cv["mae_exact_score"]
