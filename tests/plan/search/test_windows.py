"""Windows: a plan's runs of one-part steps, and each window re-ordered to its best order."""

from __future__ import annotations

import itertools
import math

import pytest

from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.validate import check_plan
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.planner import SearchPlanner
from rap.plan.search.scores import SearchScores
from rap.plan.search.windows import polish, runs
from rap.sim.params import SimParams

from tests.plan.cases import SIX, six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)
PERFECT = TableCnn(lambda op: 0.5, score_fn=hash_score)  # predicts the simulator exactly


def scorer(cnn=PERFECT):
    return Scorer(HashSim(), cnn, ScoreCache())


def greedy_plan(problem, s):
    steps = SimPlanner().solve(problem, s).steps
    return {frozenset(st.moving) | frozenset(st.fixed): st.to_operation() for st in steps}


def worst_chain(problem):
    """A complete plan that splits the least robust single part off at every step it can (else
    greedy's step): a chain for the windows to improve."""
    plan, todo = {}, [problem.whole]
    while todo:
        s = todo.pop()
        if len(s) < 2:
            continue
        ops = [op for op in problem.candidates(s) if hash_score(op, 20) > 0
               and min(len(op.moving), len(op.fixed)) == 1]
        op = min(ops, key=lambda o: hash_score(o, 20)) if ops else problem.candidates(s)[0]
        plan[s] = op
        todo += [op.moving, op.fixed]
    return plan


def truth(problem, op) -> float:
    """The score the scorer gives: 1 for a free operation (by geometry), else HashSim's."""
    return 1.0 if problem.is_free(op) else hash_score(op, 20)


def one_part(op, rest):
    return (len(op.moving) == 1 and op.fixed == rest) or (len(op.fixed) == 1 and op.moving == rest)


def brute_force(problem, start: frozenset, end: frozenset) -> float:
    """The best product over every order of splitting ``start - end``'s parts off ``start``, one
    at a time, each step the best of its candidates."""
    best = 0.0
    for order in itertools.permutations(sorted(start - end)):
        value, s = 1.0, start
        for p in order:
            rest = s - {p}
            ops = [op for op in problem.candidates(s) if one_part(op, rest)]
            value *= max((truth(problem, op) for op in ops), default=0.0)
            s = rest
        best = max(best, value)
    return best


@pytest.mark.parametrize("name", SIX)
def test_runs_are_the_plans_one_part_steps_top_down(name):
    problem = PlanningProblem(six(name), PARAMS)
    plan = greedy_plan(problem, scorer())
    found = runs(plan, problem.whole)
    seen = [s for run in found for s in run[:-1]]
    assert len(seen) == len(set(seen))  # every step in at most one run
    for run in found:
        assert len(run) >= 3
        for s, rest in zip(run, run[1:]):
            assert one_part(plan[s], rest)
    # a one-part step followed by another one (its rest splits one part off two or more) is in
    # a run
    def rest_of(op):
        return op.fixed if len(op.moving) == 1 else op.moving

    for s, op in plan.items():
        rest = rest_of(op)
        if one_part(op, rest) and len(rest) >= 3 and one_part(plan[rest], rest_of(plan[rest])):
            assert s in seen


def test_each_window_gets_its_best_order_and_the_plan_stays_valid():
    gains = []
    for name in SIX:
        problem = PlanningProblem(six(name), PARAMS)
        s = scorer()
        plan = worst_chain(problem)
        scores = SearchScores(problem, s)  # no bounds: a perfect model's scores are the truth
        scores.simulate(plan.values())
        before = math.prod(scores.known(op) for op in plan.values())
        stats: dict = {}
        new = polish(problem, scores, plan, 3, 10 ** 6, stats)
        assert len(new) == len(plan) and new.keys() >= {problem.whole}
        after = math.prod(truth(problem, op) for op in new.values())
        assert after >= before
        # the product of the windows' best orders, by brute force, is what the plan gained
        expected = before
        for run in runs(plan, problem.whole):
            for i in range(0, len(run) - 1, 3):
                start, end = run[i], run[min(i + 3, len(run) - 1)]
                old = math.prod(truth(problem, plan[x]) for x in run[i:min(i + 3, len(run) - 1)])
                expected *= max(brute_force(problem, start, end), old) / old
        assert after == pytest.approx(expected)
        assert stats["window_gain"] == pytest.approx(after / before)
        gains.append(after / before)
    assert any(g > 1.0 for g in gains), gains  # the case matters: some window is re-ordered


def test_windows_spend_at_most_their_budget_and_none_without_one():
    problem = PlanningProblem(six("grid"), PARAMS)
    for budget in (0, 1, 3):
        s = scorer()
        plan = greedy_plan(problem, s)
        scores = SearchScores(problem, s)
        scores.simulate(plan.values())
        stats: dict = {}
        new = polish(problem, scores, plan, 4, budget, stats)
        assert stats.get("window_simulations", 0) <= budget
        if budget == 0:
            assert new == plan


@pytest.mark.parametrize("name", SIX)
def test_the_beam_with_windows_plans_validly_and_never_worse(name):
    problem = PlanningProblem(six(name), PARAMS)
    model = TableCnn(lambda op: 0.5, score_fn=lambda op: 1.0 - hash_score(op))  # misleading
    off = SearchPlanner(max_operations=1, window=0).solve(problem, scorer(model))
    on = SearchPlanner(max_operations=1, window=3).solve(problem, scorer(model))
    assert check_plan(problem.assembly, on.steps) == []
    assert on.robustness >= off.robustness
    assert on.bound["robustness_upper"] >= on.robustness
