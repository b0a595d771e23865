"""Greedy's start: the search's first complete plan, never beaten by a worse one; a time limit caps
it; and the plan's bound is computed outside the caller's budget."""

from __future__ import annotations

import math

import pytest

from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus
from rap.plan.report.validate import check_plan
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Budget, Scorer
from rap.plan.search.planner import SearchPlanner
from rap.plan.search.scores import SearchScores
from rap.plan.search.start import greedy_start
from rap.sim.params import SimParams

from tests.plan.cases import SIX, six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)
# a model that predicts the opposite of the simulator: it misleads every choice it makes
LIAR = TableCnn(lambda op: 0.5, score_fn=lambda op: 1.0 - hash_score(op))


def scorer(cnn=LIAR):
    return Scorer(HashSim(), cnn, ScoreCache())


def test_greedy_start_is_greedy_plan_with_every_candidate_known():
    problem = PlanningProblem(six("grid"), PARAMS)
    greedy = SimPlanner().solve(problem, scorer(None))
    s = scorer()
    scores = SearchScores(problem, s)
    stats: dict = {}
    start = greedy_start(problem, s, scores, stats)
    first = start.sequence
    assert start.complete and start.simulations == stats["greedy_simulations"] > 0
    assert {op.key(problem.geometry_hash) for _, op in first} == {
        st.to_operation().key(problem.geometry_hash) for st in greedy.steps}
    assert stats["greedy_robustness"] == pytest.approx(greedy.robustness)
    for sub, _ in first:  # every candidate greedy simulated is exact for the search
        assert all(scores.is_simulated(op) for op in problem.candidates(sub))
    assert stats["greedy_known"] == len(scores.simulated) == stats["greedy_simulations"]


def test_a_misled_exact_search_never_returns_a_plan_worse_than_greedy():
    """From ``greedy_from`` parts the exact search starts from greedy's plan: a model that lies
    cannot make it worse than greedy, while the same search without the start is worse on some
    assemblies (so the start is what guarantees it)."""
    worse_without = []
    for name in SIX:
        problem = PlanningProblem(six(name), PARAMS)
        greedy = SimPlanner().solve(problem, scorer(None))
        for simulations in (0, 4, 200):
            found = SearchPlanner(greedy_from=2, simulations=simulations).solve(problem,
                                                                                scorer())
            assert found.stats["search"] == "exact" and found.stats["greedy_steps"] > 0
            assert check_plan(problem.assembly, found.steps) == []
            assert found.robustness >= greedy.robustness * (1 - 1e-12), (name, simulations)
        alone = SearchPlanner(greedy_from=10 ** 6, simulations=4).solve(problem, scorer())
        assert "greedy_steps" not in alone.stats
        worse_without.append(alone.robustness < greedy.robustness)
    assert any(worse_without), worse_without


def test_improvement_is_budgeted_by_greedy_simulations():
    problem = PlanningProblem(six("hexagon"), PARAMS)
    for improve in (0.0, 0.5, 1.0):
        r = SearchPlanner(greedy_from=2, improve=improve).solve(problem, scorer())
        assert r.stats["search_budget"] == math.ceil(improve * r.stats["greedy_simulations"])
        assert r.stats["refine_simulations"] <= r.stats["search_budget"]
    capped = SearchPlanner(greedy_from=2, improve=100.0, simulations=7).solve(problem, scorer())
    assert capped.stats["search_budget"] == 7


def test_a_time_limit_cuts_greedy_and_the_model_chooses_its_levels_left():
    """An anytime greedy: past its share of the limit, greedy's levels left are the model's
    choices, so a complete plan comes back whatever the limit."""
    problem = PlanningProblem(six("triangles"), PARAMS)
    for max_operations in (10 ** 6, 1):  # exact, beam
        r = SearchPlanner(greedy_from=2, time_limit=1e-9,
                          max_operations=max_operations).solve(problem, scorer())
        assert r.status is PlanStatus.FOUND and check_plan(problem.assembly, r.steps) == []
        assert r.stats["greedy_robustness"] is None  # not all simulated
        assert r.stats["greedy_by_model"] == r.stats["greedy_steps"] == len(r.steps)
        assert r.stats["greedy_simulations"] == 0


def test_the_bound_is_computed_outside_the_callers_spent_budget():
    """A request's budget that runs out after the search (during the evaluation) must not fail
    the plan's bound: it is computed outside the budget, as the evaluation is."""
    problem = PlanningProblem(six("grid"), PARAMS)

    class LateBudget(SearchPlanner):
        def _plan(self, run):
            steps = super()._plan(run)
            run.scorer.budget = Budget(max_seconds=0.0)  # spent from here on
            return steps

    s = scorer(TableCnn(lambda op: 0.5, score_fn=hash_score))
    r = LateBudget().solve(problem, s)
    assert r.status is PlanStatus.FOUND and r.bound is not None
    assert r.bound["robustness_upper"] >= r.robustness


@pytest.mark.parametrize("name", SIX)
def test_with_an_exhaustive_budget_greedys_start_changes_nothing_the_exact_search_finds(name):
    """Branch and bound on trivial bounds with every simulation it wants: the search finds the
    optimum with greedy's start exactly as without it (the start only adds what it knows)."""
    from rap.model.calibration import ScoreBounds
    from rap.plan.planners.optimal import OptimalPlanner

    problem = PlanningProblem(six(name), PARAMS)
    best = OptimalPlanner().solve(problem, scorer(None))
    plans = [SearchPlanner(bounds=ScoreBounds.trivial(), upper=1.0, simulations=10 ** 6,
                           improve=10 ** 6, greedy_from=start).solve(problem, scorer())
             for start in (2, 10 ** 6)]
    for found in plans:
        assert check_plan(problem.assembly, found.steps) == []
        assert found.robustness == pytest.approx(best.robustness, rel=1e-12)
    assert "greedy_steps" in plans[0].stats and "greedy_steps" not in plans[1].stats
