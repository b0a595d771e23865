"""Greedy's anytime finish: when a level spends the scorer's budget, ``finish`` chooses it and
every later level, so a complete plan comes back; without ``finish`` the budget ends the plan."""

from __future__ import annotations

from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus, PlanStep
from rap.plan.report.validate import check_plan
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Budget, Scorer
from rap.sim.params import SimParams

from tests.plan.cases import six
from tests.plan.standins import HashSim

PARAMS = SimParams(trials=10)


def first_candidate(problem, scorer, cands, stats):
    scorer.budget = Budget()  # the finish runs outside the spent budget
    return [PlanStep.of(c[0], "model") for c in cands]


def test_a_spent_budget_ends_greedy_without_a_finish_and_is_finished_with_one():
    problem = PlanningProblem(six("grid"), PARAMS)
    whole = SimPlanner().solve(problem, Scorer(HashSim(), None, ScoreCache()))
    spent = SimPlanner().solve(problem, Scorer(HashSim(), None, ScoreCache(),
                                               Budget(max_simulations=6)))
    assert spent.status is PlanStatus.BUDGET_SPENT
    planner = SimPlanner()
    planner.finish = first_candidate
    done = planner.solve(problem, Scorer(HashSim(), None, ScoreCache(),
                                         Budget(max_simulations=6)))
    assert done.status is PlanStatus.FOUND and check_plan(problem.assembly, done.steps) == []
    assert done.stats["finished_levels"] >= 1
    assert len(done.steps) == len(problem.whole) - 1
    # the levels before the budget are greedy's own choices
    top = [s for s in whole.steps if set(s.moving) | set(s.fixed) == set(problem.whole)]
    got = [s for s in done.steps if set(s.moving) | set(s.fixed) == set(problem.whole)]
    assert [(s.moving, s.fixed) for s in top] == [(s.moving, s.fixed) for s in got]
