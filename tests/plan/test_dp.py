"""dp_choice_bounded: the full DP's value and choices, exactly, with fewer operations scored; the
full DP's expected-attempts objective on a hand-built graph and against brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.plan.dp import dp_choice, dp_choice_bounded, dp_tree
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams
from rap.stats import expected_attempts

from tests.plan.cases import SIX, six


def graph_of(name):
    problem = PlanningProblem(six(name), SimParams(trials=10))
    return reachable(problem), problem.whole


def tables(graph, rng, kind):
    """Scores per subassembly: continuous, coarse (many exact ties) or with zeros."""
    out = {}
    for s, c in graph.items():
        if kind == "continuous":
            v = rng.random(len(c))
        elif kind == "ties":
            v = rng.integers(7, 11, len(c)) / 10  # 0.7 .. 1.0: ties everywhere
        else:
            v = rng.choice([0.0, 0.5, 0.9, 1.0], len(c))
        out[s] = [float(x) for x in v]
    return out


@pytest.mark.parametrize("name", SIX)
@pytest.mark.parametrize("kind", ["continuous", "ties", "zeros"])
def test_same_value_and_tree_as_the_full_dp(name, kind):
    graph, whole = graph_of(name)
    rng = np.random.default_rng([len(name), len(kind)])
    for _ in range(5):
        table = tables(graph, rng, kind)
        asked = []
        best, arg = dp_choice(graph, table)
        value, tree = dp_choice_bounded(graph, lambda s: asked.append(s) or table[s], whole)
        if best[whole] <= 0:
            assert (value, tree) == (0.0, {})
            continue
        assert value == best[whole]  # the same floats, not merely close
        assert tree == dp_tree(graph, arg, whole)
        assert set(asked) <= set(graph)  # visited again with a lower bar: asked again


def test_it_scores_less_than_the_whole_graph():
    graph, whole = graph_of("grid")
    rng = np.random.default_rng(1)
    table = {s: [float(x) for x in 0.5 + 0.5 * rng.random(len(c)) ** 0.2] for s, c in graph.items()}
    asked = set()
    dp_choice_bounded(graph, lambda s: asked.add(s) or table[s], whole)
    scored = sum(len(graph[s]) for s in asked)
    assert scored < sum(len(c) for c in graph.values())


def test_a_single_part_and_a_dead_end():
    graph, whole = graph_of("hexagon")
    assert dp_choice_bounded(graph, lambda s: [], frozenset(["x"])) == (1.0, {})
    dead = {s: () if s == whole else c for s, c in graph.items()}
    assert dp_choice_bounded(dead, lambda s: [1.0] * len(dead[s]), whole) == (0.0, {})


# -- the expected attempts (dp_choice(..., objective="attempts")) --------------------------------
def _op(moving, fixed):
    from rap.operation import Operation

    return Operation(frozenset(moving), frozenset(fixed), (1.0, 0.0))


#: {a, b, c}: take c off (score 1.0), then split a from b (0.5): R 0.5, attempts 1 + 2 = 3; or
#: take a off (0.7), then b from c (0.7): R 0.49, attempts 2 / 0.7 = 2.857; and a dead end first
#: (score 0). R chooses the first plan, the expected attempts the second.
ABC = frozenset("abc")
CHOICES = {ABC: [_op("a", "bc"), _op("c", "ab"), _op("a", "bc")],
           frozenset("ab"): [_op("a", "b")], frozenset("bc"): [_op("b", "c")]}
SCORES = {ABC: [0.0, 1.0, 0.7], frozenset("ab"): [0.5], frozenset("bc"): [0.7]}


def test_the_objectives_choose_different_plans_with_exact_values():
    best, arg = dp_choice(CHOICES, SCORES)
    assert best[ABC] == 0.5 and arg[ABC] == 1
    assert dp_tree(CHOICES, arg, ABC) == {ABC: (1, CHOICES[ABC][1]),
                                          frozenset("ab"): (0, CHOICES[frozenset("ab")][0])}
    best, arg = dp_choice(CHOICES, SCORES, objective="attempts")
    assert best[ABC] == 2 * (1 / 0.7) and arg[ABC] == 2  # the zero-score candidate never chosen
    assert best[frozenset("ab")] == 2.0 and best[frozenset("bc")] == 1 / 0.7
    assert dp_tree(CHOICES, arg, ABC) == {ABC: (2, CHOICES[ABC][2]),
                                          frozenset("bc"): (0, CHOICES[frozenset("bc")][0])}


def test_attempts_ties_go_to_the_first_and_zero_scores_are_dead_ends():
    tie = {**SCORES, ABC: [0.0, 0.5, 0.5], frozenset("bc"): [0.5]}  # 2 + 2 either way
    best, arg = dp_choice(CHOICES, tie, objective="attempts")
    assert best[ABC] == 4.0 and arg[ABC] == 1
    dead = {**SCORES, ABC: [0.0, 1.0, 0.7], frozenset("ab"): [0.0], frozenset("bc"): [0.0]}
    best, arg = dp_choice(CHOICES, dead, objective="attempts")
    assert best[ABC] == math.inf and ABC not in arg  # no plan whose every step can succeed
    with pytest.raises(ValueError, match="objective 'speed': choose one of robustness, attempts"):
        dp_choice(CHOICES, SCORES, objective="speed")


@pytest.mark.parametrize("name", ["hexagon", "rectilinear"])
def test_attempts_is_the_least_sum_of_inverse_scores_over_every_tree(name):
    """Against brute force: every disassembly tree of the graph enumerated."""
    graph, whole = graph_of(name)
    rng = np.random.default_rng(len(name))
    table = {s: [float(x) for x in rng.choice([0.0, 0.3, 0.6, 0.9, 1.0], len(c))]
             for s, c in graph.items()}

    def sums(s):  # every tree's sum of 1/r below s
        if len(s) < 2:
            return [0.0]
        return [expected_attempts(r) + x + y for op, r in zip(graph[s], table[s])
                for x in sums(op.moving) for y in sums(op.fixed)]

    best, _ = dp_choice(graph, table, objective="attempts")
    assert best[whole] == pytest.approx(min(sums(whole)))
