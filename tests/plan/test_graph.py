"""rap.plan.graph: the reachable-subassembly walk, its operation budget, the DP and its trees."""

from __future__ import annotations

import pytest

from rap.plan.dp import argmax_first, dp_choice, dp_tree
from rap.plan.graph import TooLarge, assembly_order, dead_end, reachable
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStep
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROW3, memory, six


def test_the_walk_reaches_every_split_side_once_and_stops_at_its_budget():
    problem = PlanningProblem(six("rectilinear"), SimParams(trials=10))
    graph = reachable(problem)
    assert problem.whole in graph and all(len(s) >= 2 for s in graph)
    for s, cands in graph.items():
        assert cands == problem.candidates(s)
        for op in cands:
            assert op.moving | op.fixed == s
            assert all(side in graph for side in (op.moving, op.fixed) if len(side) >= 2)
    n = sum(len(c) for c in graph.values())
    assert reachable(problem, n) == graph
    with pytest.raises(TooLarge):
        reachable(problem, n - 1)


def test_a_single_part_has_an_empty_graph_and_an_interlocked_whole_is_the_dead_end():
    one = {"name": "one", "parts": [ROW3["parts"][0]]}
    assert reachable(PlanningProblem(memory(one), SimParams(trials=10))) == {}
    problem = PlanningProblem(memory(FRAMED_HOLE), SimParams(trials=10))
    graph = reachable(problem)
    locked = [s for s, c in graph.items() if not c]
    assert frozenset({"frame", "plug"}) in locked
    assert dead_end(graph, problem.whole) == (problem.whole if not graph[problem.whole]
                                              else min(locked, key=lambda s: (len(s), sorted(s))))
    assert dead_end({problem.whole: ()}, problem.whole) == problem.whole


def test_dp_takes_the_best_product_and_the_first_candidate_on_ties():
    problem = PlanningProblem(memory(ROW3), SimParams(trials=10))
    graph = reachable(problem)
    ones = {s: [1.0] * len(c) for s, c in graph.items()}
    best, arg = dp_choice(graph, ones)
    assert best[problem.whole] == 1.0 and all(i == 0 for i in arg.values())
    tree = dp_tree(graph, arg, problem.whole)
    assert set(tree) <= set(graph) and problem.whole in tree
    assert len(tree) == len(problem.whole) - 1
    half = {s: [0.5] * len(c) for s, c in graph.items()}
    assert dp_choice(graph, half)[0][problem.whole] == 0.5 ** (len(problem.whole) - 1)
    assert argmax_first([0.2, 0.7, 0.7, 0.1]) == 1 and argmax_first([]) == 0


def test_assembly_order_builds_both_sides_before_joining_them():
    problem = PlanningProblem(memory(ROW3), SimParams(trials=10))
    graph = reachable(problem)
    _, arg = dp_choice(graph, {s: [1.0] * len(c) for s, c in graph.items()})
    choice = {s: PlanStep.of(op, "sim") for s, (_, op) in dp_tree(graph, arg, problem.whole).items()}
    steps = assembly_order(choice, problem.whole)
    assert len(steps) == len(problem.whole) - 1
    assert frozenset(steps[-1].moving) | frozenset(steps[-1].fixed) == problem.whole
    built = set()
    for st in steps:  # each side is a single part or a subassembly built by an earlier step
        for side in (frozenset(st.moving), frozenset(st.fixed)):
            assert len(side) == 1 or side in built
        built.add(frozenset(st.moving) | frozenset(st.fixed))
