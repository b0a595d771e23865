"""Planner logic and plan validity: the six assemblies, generated tilings, interlocked inputs."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.methods import (METHODS, PAPER_RAP, RAP_FALLBACK_OPTIMISM,
                              RAP_HIGH_PROBABILITY, make_planner)
from rap.plan.planners.greedy import RapPlanner, SimPlanner
from rap.plan.planners.optimal import OptimalPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.interlocked import interlocked_message
from rap.plan.report.result import PlanStatus, is_assembly_order
from rap.plan.scoring.scorer import Budget, Scorer
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROW3, SIX, memory, six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)


def fake_scorer(cnn=None, cache=None):
    return Scorer(HashSim(), cnn, cache or ScoreCache())


def cnn_like_sim(op):
    """A fake CNN that agrees with the fake simulator (high exactly when the score >= 0.95)."""
    return 0.9 if hash_score(op) >= 0.95 else 0.2


@pytest.mark.parametrize("name", SIX)
def test_plans_of_the_six_are_valid_and_optimal_is_best(name):
    asm = six(name)
    problem = PlanningProblem(asm, PARAMS)
    scorer = fake_scorer(TableCnn(cnn_like_sim))
    results = {m: make_planner(m, samples=5).solve(problem, scorer) for m in METHODS}
    for m, r in results.items():
        assert r.status is PlanStatus.FOUND, (m, r.message)
        assert len(r.steps) == len(asm) - 1
        assert check_plan(asm, r.steps) == [], m
        assert r.robustness == pytest.approx(math.prod(s.score for s in r.steps))
    opt = results["optimal"].robustness
    assert opt >= results["rap"].robustness - 1e-12
    assert opt >= results["sim"].robustness - 1e-12
    assert results["optimal"].stats["predicted_robustness"] == pytest.approx(opt)
    st = results["optimal"].stats
    assert st["exhaustive_sequences"] >= 1 and st["dp_evaluations"] == st["operations"]


def test_generated_tilings_give_valid_plans():
    gen = pytest.importorskip("rap.geometry.families.simple")
    rng = np.random.default_rng(3)
    assemblies = [gen.grid(3), gen.random_tiling(6, rng), gen.random_tiling(8, rng)]
    for asm in assemblies:
        problem = PlanningProblem(asm, PARAMS)
        for planner in (SimPlanner(), OptimalPlanner(), RapPlanner(high_probability=0.5, fallback_optimism=1.0)):
            r = planner.solve(problem, fake_scorer(TableCnn(cnn_like_sim)))
            assert r.status is PlanStatus.FOUND
            assert check_plan(asm, r.steps) == [], (asm.name, planner.name)


def test_rap_without_high_predictions_falls_back_to_the_sim_baseline():
    problem = PlanningProblem(six("hexagon"), PARAMS)
    rap = RapPlanner(high_probability=0.5, fallback_optimism=1.0).solve(problem, fake_scorer(TableCnn(lambda op: 0.1)))
    sim = SimPlanner().solve(problem, fake_scorer())
    assert [s.to_json()["moving"] for s in rap.steps] == [s.to_json()["moving"] for s in sim.steps]
    assert rap.stats["fallbacks"] == rap.stats["decisions"] > 0
    assert all(s.source == "sim" and s.confidence is None for s in rap.steps)


def test_rap_fallback_k_all_is_the_papers_rule_and_k_limits_the_simulations():
    problem = PlanningProblem(six("triangles"), PARAMS)
    low = lambda op: 0.4 * hash_score(op)  # noqa: E731: never high, but a ranking
    paper = RapPlanner(high_probability=0.5, fallback_optimism=1.0).solve(problem, fake_scorer(TableCnn(low)))
    every = RapPlanner(fallback_k=10 ** 6, **PAPER_RAP).solve(problem, fake_scorer(TableCnn(low)))
    assert [s.to_json() for s in every.steps] == [s.to_json() for s in paper.steps]
    assert every.stats["fallback_candidates"] == paper.stats["fallback_candidates"]
    for k in (1, 2, 3):
        r = RapPlanner(fallback_k=k, high_probability=0.5, fallback_optimism=1.0).solve(problem, fake_scorer(TableCnn(low)))
        assert r.status is PlanStatus.FOUND and check_plan(problem.assembly, r.steps) == []
        assert r.stats["fallbacks"] == r.stats["decisions"]
        assert r.stats["fallback_candidates"] <= k * r.stats["decisions"]  # k per decision
        assert r.stats["fallback_candidates"] < paper.stats["fallback_candidates"]
    one = RapPlanner(fallback_k=1, high_probability=0.5, fallback_optimism=1.0).solve(problem, fake_scorer(TableCnn(low)))
    whole = problem.candidates(problem.whole)
    top = max(range(len(whole)), key=lambda j: (low(whole[j]), -j))
    assert frozenset(one.steps[-1].moving) == whole[top].moving  # k = 1: the model's choice
    with pytest.raises(ValueError, match="fallback_k 0: choose an integer >= 1"):
        make_planner("rap", fallback_k=0)  # the options are checked where declared


def test_rap_takes_the_most_confident_high_candidate_without_simulating():
    problem = PlanningProblem(six("triangles"), PARAMS)
    cnn = TableCnn(lambda op: 0.5 + 0.4 * hash_score(op))  # every candidate "high"
    scorer = fake_scorer(cnn)
    r = RapPlanner(high_probability=0.5, fallback_optimism=1.0).solve(problem, scorer)
    assert r.stats["fallbacks"] == 0
    assert r.stats["sim_run"] == r.stats["eval_simulations"] == len(r.steps)  # evaluation only
    assert all(s.source == "model" and s.confidence >= 0.5 for s in r.steps)
    # one CNN batch per level of the decomposition; each subassembly's candidates all in it
    assert len(cnn.batches) == r.stats["levels"]
    whole = problem.candidates(problem.whole)
    assert cnn.batches[0] == len(whole)
    first = max(whole, key=lambda op: 0.5 + 0.4 * hash_score(op))
    assert set(r.steps[-1].moving) | set(r.steps[-1].fixed) == set(problem.whole)
    assert frozenset(r.steps[-1].moving) == first.moving


def test_budget_spent_is_a_status():
    problem = PlanningProblem(six("grid"), PARAMS)
    scorer = Scorer(HashSim(), None, ScoreCache(), Budget(max_simulations=2))
    r = SimPlanner().solve(problem, scorer)
    assert r.status is PlanStatus.BUDGET_SPENT and "budget" in r.message
    assert r.to_json()["feasible"] is None


def test_interlocked_assembly_is_infeasible_and_names_the_parts():
    problem = PlanningProblem(memory(FRAMED_HOLE), PARAMS)
    for m in METHODS:
        r = make_planner(m, samples=3).solve(problem, fake_scorer(TableCnn(lambda op: 0.9)))
        assert r.status is PlanStatus.INFEASIBLE
        assert set(r.interlocked) == {"frame", "plug"}
        assert r.to_json() == {"format": 3, "assembly": "framed-hole", "method": m, "feasible": False,
                               "interlocked": ["frame", "plug"], "message": r.message}
        assert r.message == interlocked_message("framed-hole", ["frame", "plug"])


def test_real_simulator_scores_are_cached_and_reused(tmp_path):
    asm = memory(ROW3)
    problem = PlanningProblem(asm, SimParams(trials=8), root_seed=7)
    path = tmp_path / "cache.json"
    r1 = SimPlanner().solve(problem, Scorer(LocalSimulator(), cache=ScoreCache(path)))
    assert r1.status is PlanStatus.FOUND and r1.stats["sim_run"] > 0
    ScoreCache.flush  # noqa: B018
    Scorer(LocalSimulator(), cache=ScoreCache(path))  # nothing written yet: no crash on absence
    cache = ScoreCache(path)
    r1b = SimPlanner().solve(problem, Scorer(LocalSimulator(), cache=cache))
    cache.flush()
    doc = json.loads(path.read_text())
    assert doc["format"] == "rap-farm/score-cache" and len(doc["scores"]) == r1b.stats["sim_run"]
    r2 = OptimalPlanner().solve(PlanningProblem(asm, SimParams(trials=8), root_seed=7),
                                Scorer(LocalSimulator(), cache=ScoreCache(path)))
    assert r2.stats["cache_hits"] >= len(doc["scores"])
    assert r2.robustness >= r1b.robustness - 1e-12
    assert [s.score for s in r1.steps] == [s.score for s in r1b.steps]  # deterministic per key
    assert check_plan(asm, r2.steps) == []


def test_validator_rejects_collisions_and_bad_orders():
    from types import SimpleNamespace as S

    asm = memory(ROW3)
    good = [S(moving=("c",), fixed=("b",), direction=(-1.0, 0.0)),
            S(moving=("a",), fixed=("b", "c"), direction=(1.0, 0.0))]
    assert check_plan(asm, good) == []
    through = [S(moving=("c",), fixed=("b",), direction=(-1.0, 0.0)),
               S(moving=("a",), fixed=("b", "c"), direction=(-1.0, 0.0))]  # comes in through c
    assert any("sweeps through" in p for p in check_plan(asm, through))
    sliding = [S(moving=("c",), fixed=("b",), direction=(0.0, 1.0)),
               S(moving=("a",), fixed=("b", "c"), direction=(0.0, -1.0))]
    assert check_plan(asm, sliding) == []  # sliding contact along a shared edge is fine
    unbuilt = [S(moving=("a",), fixed=("b", "c"), direction=(1.0, 0.0)),
               S(moving=("c",), fixed=("b",), direction=(-1.0, 0.0))]
    assert is_assembly_order(unbuilt, asm.ids) is not None
    assert check_plan(asm, good[:1])  # too few steps


def test_rap_breaks_ties_in_p_high_by_the_expected_score():
    # P(high) saturates at 1.0 in float32 for near-certain candidates: the most confident of
    # those is the one with the highest expected score, not the first in candidate order
    problem = PlanningProblem(six("triangles"), PARAMS)
    r = RapPlanner(high_probability=0.5, fallback_optimism=1.0).solve(problem, fake_scorer(TableCnn(lambda op: 1.0, score_fn=hash_score)))
    assert r.stats["fallbacks"] == 0
    whole = problem.candidates(problem.whole)
    best = max(range(len(whole)), key=lambda j: (hash_score(whole[j]), -j))
    assert frozenset(r.steps[-1].moving) == whole[best].moving


def test_rap_best_first_fallback_with_a_perfect_ranking_is_the_sim_baseline_at_two_per_decision():
    problem = PlanningProblem(six("triangles"), PARAMS)
    perfect = TableCnn(lambda op: 0.4 * hash_score(op), score_fn=hash_score)  # never high
    r = RapPlanner(fallback_optimism=0.0, high_probability=0.5).solve(problem, fake_scorer(perfect))
    sim = SimPlanner().solve(problem, fake_scorer())
    assert [s.to_json() for s in r.steps] == [s.to_json() for s in sim.steps]
    assert r.stats["fallbacks"] == r.stats["decisions"]
    assert r.stats["fallback_candidates"] <= 2 * r.stats["decisions"]  # one round each
    assert r.stats["fallback_candidates"] < sim.stats["sim_run"] - sim.stats["eval_simulations"]


def test_rap_fallback_optimism_one_is_the_papers_rule_in_one_batch_per_level():
    problem = PlanningProblem(six("triangles"), PARAMS)
    low = TableCnn(lambda op: 0.1, score_fn=lambda op: 0.5)  # no ranking, no high candidate
    scorer = fake_scorer(low)
    paper = make_planner("rap", **PAPER_RAP).solve(problem, scorer)
    sim = SimPlanner().solve(problem, fake_scorer())
    assert [s.to_json() for s in paper.steps] == [s.to_json() for s in sim.steps]
    assert paper.stats["fallback_candidates"] == sim.stats["sim_run"] - sim.stats["eval_simulations"]
    # one simulator batch per level (the evaluation finds every chosen step's score cached)
    assert scorer.stats.sim_calls == paper.stats["levels"]
    assert vars(make_planner("rap", **PAPER_RAP)) == vars(RapPlanner(high_probability=0.5, fallback_optimism=1.0))


def test_rap_defaults_and_a_capped_best_first_fallback():
    rap = make_planner("rap")
    assert (rap.high_probability, rap.fallback_optimism, rap.fallback_k) == (
        RAP_HIGH_PROBABILITY, RAP_FALLBACK_OPTIMISM, None)
    problem = PlanningProblem(six("triangles"), PARAMS)
    flat = TableCnn(lambda op: 0.1, score_fn=lambda op: 0.5)
    capped = RapPlanner(fallback_optimism=0.4, fallback_k=3, high_probability=0.5).solve(problem, fake_scorer(flat))
    assert capped.stats["fallbacks"] == capped.stats["decisions"]
    assert capped.stats["fallback_candidates"] <= 3 * capped.stats["decisions"]
    assert check_plan(problem.assembly, capped.steps) == []
    with pytest.raises(ValueError, match=r"fallback_optimism 1.5: choose a number in \[0, 1\]"):
        make_planner("rap", fallback_optimism=1.5)
