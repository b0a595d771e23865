"""research.perturbed_starts: the DP wrapper plans as the optimal planner does; a perturbed-start
score is seeded, and pushing the fixed parts off their places costs a tight fit successes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from rap.execution.error_model import ErrorModel
from rap.io import load_assembly
from rap.plan.graph import reachable
from rap.plan.planners.optimal import OptimalPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams
from research.perturbed_starts import OFFSETS, best_sequence, perturbed_score

ROOT = Path(__file__).resolve().parents[2]


def test_best_sequence_is_the_optimal_planners_plan():
    asm = load_assembly(ROOT / "assemblies" / "cells" / "arch.json")
    problem = PlanningProblem(asm, SimParams(trials=20), 3)
    scorer = Scorer(LocalSimulator(processes=1), None, ScoreCache())
    want = OptimalPlanner().solve(problem, scorer)
    graph = reachable(problem)
    ops = [op for c in graph.values() for op in c]
    score = dict(zip((problem.key(op) for op in ops), scorer.scores(problem, ops)))
    product, seq = best_sequence(problem, graph, score)
    assert seq == tuple(s.to_operation() for s in want.steps)
    assert abs(product - want.robustness) < 1e-12


def test_perturbed_score_is_seeded_and_offsets_cost_a_tight_fit():
    asm = load_assembly(ROOT / "assemblies" / "cells" / "side-peg.json")
    params = SimParams(trials=40)
    problem = PlanningProblem(asm, params, 0)
    op = next(op for c in reachable(problem).values() for op in c if not problem.is_free(op))
    recorded = np.array(json.loads(OFFSETS.read_text())["offsets"], dtype=float)
    assert len(recorded) > 1000 and (recorded[:, 0] >= 0).all()
    still = np.zeros((1, 2))
    far = np.array([[6.0, 0.2]])  # six tolerance radii off, turned 0.2 rad: the peg cannot enter
    seed = problem.seed(op)
    exact = perturbed_score(asm, op, params, ErrorModel.zero(), 1.0, still, seed)
    assert exact == perturbed_score(asm, op, params, ErrorModel.zero(), 1.0, still, seed)
    assert 0 <= exact <= params.trials
    pushed = perturbed_score(asm, op, params, ErrorModel.zero(), 1.0, far, seed)
    assert pushed < exact
