"""research.perturbed_starts: the DP wrapper plans as the optimal planner does (the perturbed-start
score itself is rap.execution.perturbed's, tested in tests/execution/test_perturbed.py)."""

from __future__ import annotations

from pathlib import Path

from rap.io import load_assembly
from rap.plan.graph import reachable
from rap.plan.planners.optimal import OptimalPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams
from research.perturbed_starts import best_sequence

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
