"""The search's run state (rap.plan.search.run): one per call, passed explicitly, so that searches
nest and run side by side on one planner; decisions on its typed fields, stats written only."""

from __future__ import annotations

import threading

import pytest

from rap.plan.problem import PlanningProblem
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.planner import SearchPlanner
from rap.plan.search.run import STOPS, SearchRun
from rap.sim.params import SimParams

from tests.plan.cases import six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)


def _cnn():
    return TableCnn(lambda op: 0.5, score_fn=lambda op: 0.9 * hash_score(op))


def _scorer(sim=None):
    return Scorer(sim or HashSim(), _cnn(), ScoreCache())


def _same(a, b):
    assert [(s.moving, s.fixed, s.direction, s.score) for s in a.steps] == \
        [(s.moving, s.fixed, s.direction, s.score) for s in b.steps]
    assert a.robustness == b.robustness and a.bound == b.bound and a.bound is not None


class _PlansWhileSimulating(HashSim):
    """A simulator that, on its first batch, has the same planner plan another assembly (a
    search inside a search, in one thread). With no simulation while planning, its first batch
    is the outer plan's evaluation: after the outer search, before its bound and alternatives,
    where a run kept per thread (not per call) would be the inner one's, or gone."""

    def __init__(self, planner, problem):
        super().__init__()
        self.planner, self.problem, self.inner = planner, problem, None

    def simulate_many(self, problem, ops):
        if self.inner is None:
            self.inner = self.planner.search(self.problem, _scorer())
        return super().simulate_many(problem, ops)


def test_a_search_inside_a_search_leaves_both_runs_whole():
    planner = SearchPlanner(simulations=0, alternatives=2)
    outer, inner = (PlanningProblem(six(n), PARAMS) for n in ("hexagon", "triangles"))
    sim = _PlansWhileSimulating(planner, inner)
    got = planner.search(outer, _scorer(sim))
    assert sim.inner is not None  # it did nest
    for problem, outcome in ((outer, got), (inner, sim.inner)):
        alone = planner.search(problem, _scorer())
        _same(outcome.plan, alone.plan)
        assert outcome.estimates == alone.estimates


def test_one_planner_serves_searches_side_by_side():
    planner = SearchPlanner(upper=1.0)
    problems = [PlanningProblem(six(n), PARAMS) for n in ("hexagon", "triangles", "grid")]
    alone = [planner.solve(p, _scorer()) for p in problems]
    got = [None] * len(problems)
    start = threading.Barrier(len(problems))

    def plan(i):
        start.wait()
        got[i] = planner.solve(problems[i], _scorer())

    threads = [threading.Thread(target=plan, args=(i,)) for i in range(len(problems))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(alone, got):
        _same(a, b)


class _WriteOnly(dict):
    """Stats the search may write but never read back."""

    def __getitem__(self, key):
        raise AssertionError(f"the search read stats[{key!r}]")

    def get(self, key, default=None):
        raise AssertionError(f"the search read stats.get({key!r})")

    def __contains__(self, key):
        raise AssertionError(f"the search asked whether {key!r} is in its stats")


@pytest.mark.parametrize("options", [
    {},  # exact, settled
    {"simulations": 3, "upper": 1.0},  # exact, stopped by the budget: the best simulated plan
    {"gap": 0.05, "upper": 0.5},  # phase 2
    {"greedy_from": 2},  # greedy's start, budgeted by its simulations
    {"time_limit": 1e-9, "upper": 1.0},  # stopped by the time
    {"max_operations": 1, "beam_width": 2},  # the beam, greedy's plan, the windows
    {"max_operations": 1, "gap": 0.05},  # the beam's phase 2
])
def test_the_search_decides_on_its_run_and_only_writes_its_stats(options):
    problem = PlanningProblem(six("triangles"), PARAMS)
    run = SearchRun(problem, _scorer(), _WriteOnly())
    steps = SearchPlanner(**options)._plan(run)
    stats = dict(run.stats)  # read here, by the test
    assert len(steps) == len(problem.whole) - 1 and run.plan is not None
    assert run.stopped in STOPS and stats["stopped"] == run.stopped
    assert stats["search_budget"] == run.budget
    assert stats["refine_simulations"] == run.refined <= run.budget
    assert ("phase1_simulations" in stats) == (run.phase1 is not None)
    if run.phase1 is not None:
        assert stats["phase1_simulations"] == run.phase1
    assert (run.graph is None) == (stats["search"] == "beam") == (run.beam is not None)
    assert (run.start is not None) == ("greedy_simulations" in stats)
    with pytest.raises(ValueError, match="stopped 'tired'"):
        run.stop("tired")
