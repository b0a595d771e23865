"""rap.plan.interlocked: the named set is interlocked and minimal; no method names a set that a
one-step translation separates, and a search that gives up where nothing is interlocked says so."""

from __future__ import annotations

from itertools import combinations

import pytest

from rap.plan.interlocked import interlocked_message, minimal_interlocked
from rap.plan.methods import make_planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, memory
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)


def separable(problem, parts) -> bool:
    return bool(problem.splits(frozenset(parts), False))


def test_the_shrink_keeps_only_what_locks():
    locked = {frozenset("ab"), frozenset("abc"), frozenset("abcd")}  # a and b lock each other
    got = minimal_interlocked("dcba", lambda s: any(x <= s for x in locked if len(x) == 2))
    assert got == frozenset("ab")
    assert minimal_interlocked("xy", lambda s: False) == frozenset("xy")  # not interlocked: as is


@pytest.mark.parametrize("method", ["search", "rap", "sim", "optimal", "random"])
def test_every_method_names_a_minimal_verified_interlock(method):
    problem = PlanningProblem(memory(FRAMED_HOLE), PARAMS)
    scorer = Scorer(HashSim(), TableCnn(hash_score), ScoreCache())
    planner = make_planner(method, samples=3) if method == "random" else make_planner(method)
    result = planner.solve(problem, scorer)
    assert result.status is PlanStatus.INFEASIBLE
    named = result.interlocked
    assert named and not separable(problem, named)  # no one-step translation separates it
    for k in range(2, len(named)):  # and nothing smaller of it is interlocked
        assert all(separable(problem, sub) for sub in combinations(named, k))
    assert result.message == interlocked_message("framed-hole", named)


def test_a_search_that_gives_up_never_claims_an_interlock():
    from rap.plan.cell.rules import blocked_by

    problem = PlanningProblem(memory(FRAMED_HOLE), PARAMS)
    whole = problem.whole  # not interlocked: the side part slides away
    assert separable(problem, whole)
    culprit, line = blocked_by(problem, whole)
    assert culprit == whole and "not interlocked" in line and "it is interlocked" not in line
