"""rap.plan.search.screening and SearchPlanner(sequential=...): operations shown too weak stop early and
stay partly simulated; the plan's steps keep their full scores; without chunks nothing changes."""

from __future__ import annotations

import hashlib
import math

import pytest

from rap.model.calibration import ScoreBounds
from rap.plan.search.scores import SearchScores
from rap.plan.scoring.cache import ScoreCache
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.screening import screen, thresholds
from rap.plan.search.planner import SearchPlanner
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams
from rap.sim.sequential import SequentialTest

from tests.plan.cases import six
from tests.plan.standins import BinomialSim, HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=100)


def wide(op) -> float:
    """A truth spread over [0.05, 1]: some operations are far weaker than any model says."""
    h = int(hashlib.sha256(op.key("wide").encode()).hexdigest()[:8], 16)
    return 0.85 + (h % 15) / 100 if h % 3 else 0.05 + (h % 46) / 100


def _scores(sim, name="hexagon"):
    problem = PlanningProblem(six(name), PARAMS)
    scores = SearchScores(problem, Scorer(sim, TableCnn(lambda op: 0.5), ScoreCache()),
                          ScoreBounds.trivial(), upper=1.0)
    ops = list(problem.candidates(problem.whole))
    scores.predict(ops)
    return scores, ops


def test_thresholds_are_what_keeps_the_choice_ahead_of_the_incumbent():
    scores, ops = _scores(BinomialSim(wide))
    scores.add_simulated(ops[:1], [0.8])
    chosen = ops[:3]  # the others count at their choosing scores: 0.8, then bounds of 1
    assert thresholds(scores, chosen, ops[1:3], 0.6) == pytest.approx([0.6 / 0.8] * 2)
    assert thresholds(scores, chosen, ops[1:3], 0.0) == [0.0, 0.0]  # no incumbent, no threshold


def test_weak_operations_stop_early_strong_ones_get_their_full_simulation():
    sim = BinomialSim(lambda op: 0.1 if op is weak else 0.98)
    scores, ops = _scores(sim)
    weak, strong, fresh = ops[0], ops[1], ops[2]
    test = SequentialTest(0.05, (20, 20, 20))
    spent = screen(scores, [weak, strong, fresh], [0.8, 0.8, 0.0], test)
    k = scores.key
    assert k(weak) in scores.partial and k(weak) not in scores.simulated
    s, n, up = scores.partial[k(weak)]
    assert n == 20 and up == test.upper(s, n) < 0.8  # stopped at the first look
    assert scores.of(weak) == up and scores.known(weak) == s / n
    assert scores.high(weak) == 1.0  # the reported bound keeps the model's (here trivial) bound
    assert scores.simulated[k(strong)] == 0.98 and scores.simulated[k(fresh)] == 0.98
    # weak: below after one chunk; strong: 20 of 20 is not above 0.8 yet, but not below either
    # (its rate is at least tau): the label decides
    assert [(c[1], c[2]) for c in sim.chunks] == [(0, 20), (0, 20)]
    assert spent == pytest.approx(0.4 + 2)  # two chunks of 20, two full simulations
    assert all(c.trials == 100 for _, c in scores.scorer.cache.items())  # chunks never cached
    assert scores.scorer.stats.chunk_trials == 40 and scores.scorer.stats.sim_trials == 240


def test_a_partly_simulated_operation_resumes_its_chunks_then_gets_its_label():
    sim = BinomialSim(lambda op: 0.6)
    scores, ops = _scores(sim)
    op, test = ops[0], SequentialTest(0.05, (20, 20, 20))
    screen(scores, [op], [0.99], test)  # 0.6 against 0.99: below at once
    assert scores.partial[scores.key(op)][1] == 20
    s, n, _ = scores.partial[scores.key(op)]
    assert s < 0.65 * n  # a later choice asks against 0.65: not decided by 60 trials
    screen(scores, [op], [0.65], test)
    assert scores.simulated[scores.key(op)] == 0.6 and scores.key(op) not in scores.partial
    assert [c[1] for c in sim.chunks] == [0, 1, 2] and sim.labels == 1  # resumed, then full


def test_without_chunks_in_the_backend_every_simulation_is_full():
    scores, ops = _scores(HashSim(trials=100))
    assert not scores.scorer.chunked
    assert screen(scores, ops[:2], [0.9, 0.9], SequentialTest(0.05, (20, 20, 20))) == 2
    assert not scores.partial and len(scores.simulated) == 2


def _search(sim, sequential, name="triangles"):
    problem = PlanningProblem(six(name), PARAMS)
    scorer = Scorer(sim, TableCnn(lambda op: 0.5, lambda op: 0.9), ScoreCache())
    planner = SearchPlanner(simulations=400, optimism=1.0, sequential=sequential,
                            bounds=ScoreBounds.trivial())
    return problem, scorer, planner.solve(problem, scorer)


def test_a_sequential_search_reports_full_scores_for_every_step():
    problem, scorer, result = _search(BinomialSim(wide), 0.05)
    st = result.stats
    assert st["search_partial"] > 0 and st["chunk_runs"] > 0  # some operations stopped early
    labels = {k: c for k, c in scorer.cache.items()}
    assert all(c.trials == 100 for c in labels.values())  # no chunk became a label
    for step in result.steps:  # every step's score is its 100-trial label
        assert step.score == labels[problem.key(step.operation)].score
        assert step.score == round(wide(step.operation) * 100) / 100
    assert result.robustness == pytest.approx(math.prod(s.score for s in result.steps))
    assert st["search_trials"] == st["sim_trials"] - 100 * st["eval_simulations"]
    assert check_plan(problem.assembly, result.steps) == []
    # fewer trials than the same search without the test, here
    _, _, off = _search(BinomialSim(wide), None)
    assert st["search_trials"] < off.stats["sim_trials"] - 100 * off.stats["eval_simulations"]


def test_sequential_off_or_without_chunks_leaves_the_plan_unchanged():
    _, _, off = _search(HashSim(trials=100), None)
    _, _, fallback = _search(HashSim(trials=100), 0.05)  # the farm's case: no chunks
    assert [s.operation for s in fallback.steps] == [s.operation for s in off.steps]
    assert fallback.robustness == off.robustness
    for key in ("search_simulations", "sim_run", "stopped", "stopped_after"):
        assert fallback.stats.get(key) == off.stats.get(key)
    assert fallback.stats["search_partial"] == 0 and fallback.stats["chunk_runs"] == 0
    assert "search_partial" not in off.stats
