"""dp_choice_bounded: the full DP's value and choices, exactly, with fewer operations scored."""

from __future__ import annotations

import numpy as np
import pytest

from rap.plan.dp import dp_choice, dp_choice_bounded, dp_tree
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

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
