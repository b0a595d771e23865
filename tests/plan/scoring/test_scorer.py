"""The Scorer's free operations: robust by geometry, 1 without a simulation or a prediction, and
never a backend's, the cache's or the budget's (rap.plan.scoring.scorer, module doc)."""

from __future__ import annotations

import numpy as np

from rap.plan.problem import PlanningProblem
from rap.plan.scoring.scorer import Budget, Scorer
from rap.sim.params import SimParams
from tests.plan.cases import memory
from tests.plan.standins import HashSim, TableCnn

#: two touching squares (a, b) and a third (c) lying apart from both
PAIR_AND_ONE = {"name": "pair-and-one", "parts": [
    {"id": "a", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
    {"id": "b", "polygon": [[10, 0], [20, 0], [20, 10], [10, 10]]},
    {"id": "c", "polygon": [[40, 0], [50, 0], [50, 10], [40, 10]]},
]}


def _problem():
    problem = PlanningProblem(memory(PAIR_AND_ONE), SimParams(trials=10))
    ops = [op for s in (problem.whole, frozenset("ab")) for op in problem.candidates(s)]
    return problem, ops


def test_free_operations_score_1_unsimulated_and_the_rest_are_simulated():
    problem, ops = _problem()
    free = [problem.is_free(op) for op in ops]
    assert any(free) and not all(free)  # c leaves freely; a and b touch
    assert not any(problem.is_free(op) for op in problem.candidates(frozenset("ab")))
    sim = HashSim(trials=10)
    scorer = Scorer(sim, budget=Budget(max_simulations=sum(not f for f in free)))
    got = scorer.scores(problem, ops)
    assert [g for g, f in zip(got, free) if f] == [1.0] * sum(free)
    assert sim.ops == sum(not f for f in free)  # only the touching ones reached the simulator
    assert scorer.stats.sim_run == sum(not f for f in free) and scorer.stats.free == sum(free)
    assert len(scorer.cache) == sum(not f for f in free)  # free scores are not cached
    assert got == scorer.scores(problem, ops)  # the rest from the cache, within the budget


def test_free_operations_are_never_shown_to_the_model():
    problem, ops = _problem()
    free = np.array([problem.is_free(op) for op in ops])
    cnn = TableCnn(lambda op: 0.25)
    scorer = Scorer(HashSim(), cnn)
    p, e = scorer.prob_high_and_expected(problem, ops)
    assert (p[free] == 1.0).all() and (e[free] == 1.0).all()
    assert (p[~free] == 0.25).all() and (e[~free] == 0.25).all()
    assert cnn.batches == [int((~free).sum())]
    only_free = [op for op, f in zip(ops, free) if f]
    assert list(scorer.expected_scores(problem, only_free)) == [1.0] * len(only_free)
    # TableCnn answers both numbers in two calls; the free-only question called it no more
    assert scorer.stats.cnn_batches == 2 and cnn.scored == int((~free).sum())


class _FullCnn(TableCnn):
    """A stand-in that declares every capability a CNN backend may offer."""

    batch_first = True

    def __init__(self, fn, bounds):
        super().__init__(fn)
        self.bounds = bounds
        self.joint = 0

    def prob_high_and_expected(self, problem, ops):
        self.joint += 1
        return self.prob_high(problem, ops), self.expected_score(problem, ops)

    def guard_report(self, problem):
        return {"unfamiliar": True, "assembly": problem.assembly.name}


def test_the_scorer_protocol_is_declared_and_implemented():
    from rap.model.inference.cascade import CascadeScorer
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.scorer import JointCnnBackend, ScorerProtocol

    assert isinstance(Scorer(HashSim()), ScorerProtocol)
    assert not isinstance(HashSim(), ScorerProtocol)
    # the shipped CNN backends give both numbers from one pass
    assert issubclass(OperationPredictor, JointCnnBackend)
    assert issubclass(CascadeScorer, JointCnnBackend)


def test_a_backends_capabilities_are_read_by_their_declared_protocols():
    problem, ops = _problem()
    asked = int(sum(not problem.is_free(op) for op in ops))
    plain = Scorer(HashSim(), TableCnn(lambda op: 0.25))  # prob_high and expected_score only
    assert plain.bounds is None and plain.batch_first is False
    plain.prob_high_and_expected(problem, ops)
    assert plain.cnn.batches == [asked] and plain.stats.cnn_batches == 2  # two calls
    sentinel = object()
    full = Scorer(HashSim(), _FullCnn(lambda op: 0.25, sentinel))
    assert full.bounds is sentinel and full.batch_first is True
    p, e = full.prob_high_and_expected(problem, ops)
    assert full.cnn.joint == 1 and full.stats.cnn_batches == 1  # one pass
    assert (p == e).all() and sorted(set(p)) == [0.25, 1.0]
    no_cnn = Scorer(HashSim())
    assert no_cnn.bounds is None and no_cnn.batch_first is False
    # the guard's report, read through GuardedBackend; a plan's stats carry it once the model
    # was asked (rap.plan.scoring.familiarity.guard_stats)
    from rap.plan.scoring.familiarity import guard_stats

    assert full.guard_report(problem) == {"unfamiliar": True, "assembly": problem.assembly.name}
    assert guard_stats(full, problem) == {"guard": full.guard_report(problem)}
    assert plain.guard_report(problem) is None and no_cnn.guard_report(problem) is None
    assert guard_stats(plain, problem) == {} and guard_stats(no_cnn, problem) == {}
    assert guard_stats(Scorer(HashSim(), _FullCnn(lambda op: 0.25, None)), problem) == {}
