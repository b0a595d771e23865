"""research/planning_bounds.py: the counts behind the perfect-scorer bounds, on a reference graph
with seeded scores (no simulation, no model)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.plan.dp import dp_choice
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

from research import planning_bounds
from tests.plan.cases import six


@pytest.fixture(scope="module")
def bounds():
    return planning_bounds


@pytest.fixture(scope="module")
def case():
    problem = PlanningProblem(six("rectilinear"), SimParams(trials=10))
    graph = reachable(problem)
    rng = np.random.default_rng(3)
    keys = sorted({problem.key(op) for c in graph.values() for op in c})
    truth = dict(zip(keys, (rng.integers(60, 101, len(keys)) / 100).tolist()))
    return problem, graph, truth


def test_a_perfect_scorer_finds_the_optimum_scoring_at_most_the_graph(bounds, case):
    problem, graph, truth = case
    r, scored = bounds.search_counts(problem, truth, truth, bounds.optimum(problem, graph, truth))
    assert r == pytest.approx(1.0, abs=1e-12)
    assert 0 < scored <= sum(len(c) for c in graph.values())


def test_a_beam_of_one_is_simulator_only_greedy(bounds, case):
    problem, graph, truth = case
    r, scored = bounds.search_counts(problem, truth, truth, bounds.optimum(problem, graph, truth),
                                     beam_width=1)
    g = bounds.greedy_path(problem, graph, truth)
    assert scored == g["candidates"] and g["decisions"] == len(problem.whole) - 1
    # the greedy product, judged against the optimum
    best, _ = dp_choice(graph, {s: [truth[problem.key(op)] for op in c] for s, c in graph.items()})
    stack, product = [problem.whole], 1.0
    while stack:
        s = stack.pop()
        if len(s) < 2:
            continue
        scores = [truth[problem.key(op)] for op in graph[s]]
        i = max(range(len(scores)), key=lambda j: (scores[j], -j))
        product *= scores[i]
        stack += [graph[s][i].moving, graph[s][i].fixed]
    assert r == pytest.approx(product / best[problem.whole], rel=1e-12) and r <= 1.0


def test_fallbacks_counted_only_where_no_candidate_is_high(bounds, case):
    problem, graph, truth = case
    g = bounds.greedy_path(problem, graph, truth)
    assert 0 <= g["no_high"] <= g["decisions"] and g["no_high_candidates"] <= g["candidates"]
    all_high = bounds.greedy_path(problem, graph, dict.fromkeys(truth, 1.0))
    assert all_high["no_high"] == 0 and all_high["no_high_candidates"] == 0
    none_high = bounds.greedy_path(problem, graph, dict.fromkeys(truth, 0.9))
    assert none_high["no_high"] == none_high["decisions"] == len(problem.whole) - 1
    assert none_high["no_high_candidates"] == none_high["candidates"]
    assert math.isclose(bounds.HIGH, 0.95)
