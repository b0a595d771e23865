"""The search's alternatives (rap.plan.search.alternatives): the K best trees of the AND/OR graph
against every tree, and beside the search's plan, other distinct complete plans that leave the plan,
its R and its simulations as they are."""

from __future__ import annotations

import hashlib
import math

import pytest

from rap.plan.dp import dp_choice, dp_tree
from rap.plan.graph import reachable
from rap.plan.planners.base import evaluate_steps
from rap.plan.problem import PlanningProblem
from rap.plan.report.validate import check_plan
from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.alternatives import k_best
from rap.plan.search.planner import SearchPlanner
from rap.sim.params import SimParams

from tests.plan.cases import six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)
#: the assemblies whose every tree is enumerated here (2,128 to 11,076 trees)
SMALL = ("rectilinear", "mixed-square", "hexagon")


def _uniform(op) -> float:
    """A score in (0.2, 1) with no ties between operations."""
    h = int(hashlib.sha256(op.key("alternatives").encode()).hexdigest()[:12], 16)
    return 0.2 + 0.8 * (h + 1) / (16 ** 12 + 2)


def _with_zeros(op) -> float:
    """hash_score, with a third of the operations never succeeding."""
    h = int(hashlib.sha256(op.key("zeros").encode()).hexdigest()[:8], 16)
    return 0.0 if h % 3 == 0 else hash_score(op)


def every_tree(graph, score, whole) -> list[tuple[float, frozenset]]:
    """Every tree below ``whole`` with a positive product: (product, its operations), the product
    multiplied as the DP multiplies it (r * a * b)."""
    memo: dict = {}

    def trees(s):
        if len(s) < 2:
            return [(1.0, frozenset())]
        if s not in memo:
            memo[s] = [(score(op) * a * b, frozenset([op]) | x | y)
                       for op in graph[s] for a, x in trees(op.moving)
                       for b, y in trees(op.fixed) if score(op) * a * b > 0]
        return memo[s]

    return sorted(trees(whole), key=lambda t: -t[0])


@pytest.mark.parametrize("name", SMALL)
@pytest.mark.parametrize("score", [hash_score, _uniform, _with_zeros])
def test_k_best_is_the_top_of_every_tree(name, score):
    problem = PlanningProblem(six(name), PARAMS)
    graph, whole = reachable(problem), problem.whole
    truth = every_tree(graph, score, whole)
    best, arg = dp_choice(graph, {s: [score(op) for op in c] for s, c in graph.items()})
    for k in (1, 5, 40):
        asked = []

        def scores_of(s):
            asked.append(s)
            return [score(op) for op in graph[s]]

        got = k_best(graph, scores_of, whole, k)
        assert [v for v, _ in got] == [v for v, _ in truth[:k]]  # the same floats
        assert len(asked) == len(set(asked))  # each subassembly's scores asked once
        sets = [frozenset(tree.values()) for _, tree in got]
        assert len(set(sets)) == len(sets)  # distinct trees
        every = dict((ops, v) for v, ops in truth)
        for (v, tree), ops in zip(got, sets):
            assert every[ops] == v and set(tree) == {op.moving | op.fixed for op in ops}
        # the first is the optimum's DP's tree, ties to the first candidate as there
        assert got[0][0] == best[whole]
        assert got[0][1] == {s: op for s, (_, op) in dp_tree(graph, arg, whole).items()}
        if score is _uniform:  # no ties: the very trees
            assert sets == [ops for _, ops in truth[:k]]
    assert k_best(graph, lambda s: [score(op) for op in graph[s]], whole, 0) == []


def _scorer(score_fn=None):
    score_fn = score_fn or (lambda op: 0.9 * hash_score(op))  # the model underrates each step
    return Scorer(HashSim(), TableCnn(lambda op: 0.5, score_fn=score_fn), ScoreCache())


def _steps(result):
    return [(s.moving, s.fixed, s.direction, s.score, s.source, s.predicted, s.confidence)
            for s in result.steps]


#: exact; exact from greedy's plan; beam; exact with every simulation it wants by the bounds
MODES = [{}, {"greedy_from": 2}, {"max_operations": 1, "beam_width": 3},
         {"upper": 1.0, "simulations": 10 ** 6}]


@pytest.mark.parametrize("options", MODES)
@pytest.mark.parametrize("name", ["hexagon", "triangles"])
def test_alternatives_leave_the_plan_its_r_and_its_simulations_as_they_are(name, options):
    problem = PlanningProblem(six(name), PARAMS)
    plain = SearchPlanner(**options).search(problem, _scorer())
    sim = HashSim()
    outcome = SearchPlanner(alternatives=6, **options).search(
        problem, Scorer(sim, TableCnn(lambda op: 0.5, lambda op: 0.9 * hash_score(op)),
                        ScoreCache()))
    assert plain.alternatives == () and plain.estimates == ()
    a, b = plain.plan, outcome.plan
    assert _steps(a) == _steps(b) and a.robustness == b.robustness and a.bound == b.bound
    timed = ("seconds", "bound_seconds", "alternatives_seconds", "cnn_seconds", "sim_seconds")
    only = {k: v for k, v in b.stats.items() if k not in timed and "seconds" not in k}
    assert only.pop("alternatives") == len(outcome.alternatives) > 0
    for k in ("cnn_batches", "cnn_ops", "free"):  # the alternatives may predict, never simulate
        only.pop(k)
    assert only == {k: v for k, v in a.stats.items() if k in only}
    assert b.stats["sim_run"] == a.stats["sim_run"] == sim.ops
    assert b.stats["search"] == ("beam" if "max_operations" in options else "exact")


@pytest.mark.parametrize("options", MODES[:3])
def test_alternatives_are_distinct_complete_plans_best_first(options):
    problem = PlanningProblem(six("triangles"), PARAMS)
    outcome = SearchPlanner(alternatives=8, **options).search(problem, _scorer())
    plan, alts = outcome.plan, outcome.alternatives
    assert 0 < len(alts) <= 8 and len(outcome.estimates) == len(alts)
    seqs = [tuple((s.moving, s.fixed, s.direction) for s in r.steps) for r in (plan, *alts)]
    assert len(set(seqs)) == len(seqs)  # distinct, and none is the plan
    assert list(outcome.estimates) == sorted(outcome.estimates, reverse=True)
    for alt, estimate in zip(alts, outcome.estimates):
        assert alt.found and alt.method == "search" and alt.assembly == plan.assembly
        assert check_plan(problem.assembly, alt.steps) == []
        known = [s.score if s.score is not None else s.predicted for s in alt.steps]
        assert estimate == pytest.approx(math.prod(known), rel=1e-12) and estimate > 0
        for s in alt.steps:  # scored where simulated (or free), else the model's
            assert (s.score is None) == (s.source == "model")
        scored = all(s.score is not None for s in alt.steps)
        assert (alt.robustness is not None) == scored


@pytest.mark.parametrize("name", SMALL)
def test_with_a_perfect_model_the_alternatives_are_the_next_best_sequences(name):
    """The model is the simulator: the plan is the optimum, and the alternatives are the next
    best trees of all; simulated, each scores what it was estimated at."""
    problem = PlanningProblem(six(name), PARAMS)
    outcome = SearchPlanner(alternatives=5, simulations=0, upper=0.0).search(
        problem, _scorer(hash_score))
    graph = reachable(problem)
    truth = every_tree(graph, lambda op: 1.0 if problem.is_free(op) else hash_score(op),
                       problem.whole)  # a free operation scores 1, by geometry
    top = [v for v, _ in truth[:6]]
    got = sorted([outcome.plan.robustness, *outcome.estimates], reverse=True)
    assert got == pytest.approx(top, rel=1e-12)
    scorer = _scorer(hash_score)
    for alt, estimate in zip(outcome.alternatives, outcome.estimates):
        r = math.prod(s.score for s in evaluate_steps(problem, scorer, alt.steps))
        assert r == pytest.approx(estimate, rel=1e-12) and r <= outcome.plan.robustness


def test_beam_alternatives_are_the_final_beams_other_sequences():
    problem = PlanningProblem(six("grid"), PARAMS)
    for width in (1, 4):
        outcome = SearchPlanner(alternatives=100, max_operations=1, beam_width=width).search(
            problem, _scorer())
        # the beam, greedy's plan and the polished plan, less the plan itself
        assert len(outcome.alternatives) <= width + 1
        assert all(check_plan(problem.assembly, a.steps) == [] for a in outcome.alternatives)
    assert len(outcome.alternatives) >= 2


def test_a_single_part_or_no_plan_has_no_alternatives():
    from tests.plan.cases import FRAMED_HOLE, memory

    problem = PlanningProblem(memory(FRAMED_HOLE), PARAMS)
    outcome = SearchPlanner(alternatives=3).search(problem, _scorer())
    assert not outcome.plan.found and outcome.alternatives == ()
