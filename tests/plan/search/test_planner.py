"""SearchPlanner: the optimum with a perfect model, the beam beyond the budget, valid plans,
simulations spent only as asked."""

from __future__ import annotations

import numpy as np
import pytest

from rap.plan.scoring.cache import ScoreCache
from rap.plan.graph import reachable
from rap.plan.methods import make_planner
from rap.plan.planners.optimal import OptimalPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.planner import SearchPlanner
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, SIX, memory, six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)


def scorer(cnn):
    return Scorer(HashSim(), cnn, ScoreCache())


def tree(result):
    return [(s.moving, s.fixed, s.direction) for s in result.steps]


class BatchFirstCnn(TableCnn):
    """A stand-in whose batches are cheaper than its operations one at a time."""

    batch_first = True


@pytest.mark.parametrize("name", SIX)
def test_a_batch_first_scorer_gets_the_whole_graph_in_one_batch_and_the_same_plan(name):
    problem = PlanningProblem(six(name), PARAMS)
    plans = []
    for cls in (TableCnn, BatchFirstCnn):
        cnn = cls(lambda op: 0.5, score_fn=lambda op: 0.2 + 0.6 * hash_score(op))
        plans.append(SearchPlanner(simulations=40).solve(problem, scorer(cnn)))
        if cls is BatchFirstCnn:  # every operation but the free ones (1 by geometry)
            st = plans[-1].stats
            free = sum(problem.is_free(op) for ops in reachable(problem).values() for op in ops)
            assert st["search"] == "exact"
            assert st["predicted_operations"] == st["operations"] - free
            assert cnn.scored == st["predicted_operations"] and st["cnn_batches"] == 1
    assert tree(plans[0]) == tree(plans[1])
    assert plans[0].robustness == plans[1].robustness
    assert plans[0].stats["sim_run"] == plans[1].stats["sim_run"]


@pytest.mark.parametrize("name", SIX)
def test_a_perfect_model_gives_exactly_the_optimum(name):
    problem = PlanningProblem(six(name), PARAMS)
    perfect = TableCnn(lambda op: 0.5, score_fn=hash_score)  # the simulator's own scores
    found = SearchPlanner(simulations=0, upper=0.0).solve(problem, scorer(perfect))
    best = OptimalPlanner().solve(problem, scorer(None))
    assert found.status is PlanStatus.FOUND and found.stats["search"] == "exact"
    assert tree(found) == tree(best)
    assert found.robustness == pytest.approx(best.robustness)
    assert found.stats["predicted_robustness"] == pytest.approx(best.robustness)
    assert found.stats["search_simulations"] == 0  # no simulation while planning by default
    assert all(s.source in ("model", "free") for s in found.steps)  # free: 1 by geometry
    assert check_plan(problem.assembly, found.steps) == []


def test_simulations_where_they_decide_fix_a_wrong_model():
    problem = PlanningProblem(six("triangles"), PARAMS)
    best = OptimalPlanner().solve(problem, scorer(None))
    rng = np.random.default_rng(0)
    noise = {}

    def noisy(op):  # the truth plus large, fixed noise per operation
        k = op.key("noise")
        if k not in noise:
            noise[k] = float(rng.normal(0, 0.08))
        return min(1.0, max(0.0, hash_score(op) + noise[k]))

    blind = SearchPlanner(simulations=0, upper=0.0).solve(problem, scorer(TableCnn(lambda op: 0.5, noisy)))
    budget = 60
    sure = SearchPlanner(simulations=budget, upper=0.0).solve(problem, scorer(TableCnn(lambda op: 0.5, noisy)))
    assert sure.stats["search_simulations"] <= budget
    assert sure.robustness >= blind.robustness - 1e-12
    assert sure.robustness <= best.robustness + 1e-12
    assert any(s.source == "sim" for s in sure.steps)
    assert check_plan(problem.assembly, sure.steps) == []


@pytest.mark.parametrize("width", [1, 3, 8])
def test_beam_engages_beyond_the_budget_and_plans_validly(width):
    gen = pytest.importorskip("rap.geometry.families.simple")
    asm = gen.random_tiling(12, np.random.default_rng(5))
    problem = PlanningProblem(asm, PARAMS)
    cnn = TableCnn(lambda op: 0.5, score_fn=hash_score)
    r = SearchPlanner(beam_width=width, max_operations=50, simulations=0, upper=0.0).solve(problem, scorer(cnn))
    assert r.status is PlanStatus.FOUND and r.stats["search"] == "beam"
    assert r.stats["beam_width"] == width and len(r.steps) == len(asm) - 1
    assert check_plan(asm, r.steps) == []
    exact = SearchPlanner(simulations=0, upper=0.0).solve(problem, scorer(TableCnn(lambda op: 0.5, score_fn=hash_score)))
    assert r.stats["predicted_robustness"] <= exact.stats["predicted_robustness"] + 1e-12


def test_wider_beams_never_do_worse_on_the_model_score():
    gen = pytest.importorskip("rap.geometry.families.simple")
    problem = PlanningProblem(gen.random_tiling(10, np.random.default_rng(2)), PARAMS)
    got = [SearchPlanner(beam_width=w, max_operations=1, simulations=0, upper=0.0).solve(
        problem, scorer(TableCnn(lambda op: 0.5, score_fn=hash_score))).stats["predicted_robustness"]
           for w in (1, 2, 4, 16)]
    assert got[-1] >= got[0] - 1e-12


def test_interlocked_assembly_is_infeasible():
    problem = PlanningProblem(memory(FRAMED_HOLE), PARAMS)
    for planner in (SearchPlanner(simulations=0, upper=0.0), SearchPlanner(max_operations=1, simulations=0, upper=0.0)):
        r = planner.solve(problem, scorer(TableCnn(lambda op: 0.5)))
        assert r.status is PlanStatus.INFEASIBLE and r.interlocked


def _noisy_model(seed: int = 0, sd: float = 0.08, top: float = 1.0):
    rng = np.random.default_rng(seed)
    noise = {}

    def noisy(op):  # the truth plus large, fixed noise per operation
        k = op.key("noise")
        if k not in noise:
            noise[k] = float(rng.normal(0, sd))
        return min(top, max(0.0, hash_score(op) + noise[k]))

    return TableCnn(lambda op: 0.5, noisy)


@pytest.mark.parametrize("trust", [0.6, 0.8, 0.95])
def test_trusted_predictions_are_never_simulated_and_the_rest_converges(trust):
    problem = PlanningProblem(six("triangles"), PARAMS)
    s = scorer(_noisy_model())
    r = SearchPlanner(simulations=10_000, trust=trust, upper=0.0).solve(problem, s)
    assert r.status is PlanStatus.FOUND and check_plan(problem.assembly, r.steps) == []
    for step in r.steps:  # converged: each step simulated, or predicted at `trust` or more
        assert (step.source == "sim") != (step.predicted >= trust)
    untrusted = SearchPlanner(simulations=10_000, upper=0.0).solve(problem, scorer(_noisy_model()))
    assert all(step.source == "sim" for step in untrusted.steps)
    assert r.stats["search_simulations"] <= untrusted.stats["search_simulations"]


def test_trust_above_every_prediction_changes_nothing():
    problem = PlanningProblem(six("hexagon"), PARAMS)
    a = SearchPlanner(simulations=12, upper=0.0).solve(problem, scorer(_noisy_model(1, top=0.99)))
    b = SearchPlanner(simulations=12, trust=0.995, upper=0.0).solve(problem, scorer(_noisy_model(1, top=0.99)))
    assert tree(a) == tree(b) and a.stats["search_simulations"] == b.stats["search_simulations"]
    with pytest.raises(ValueError, match=r"trust 0.0: choose a score in \(0, 1\]"):
        make_planner("search", trust=0.0)  # the options are checked where declared


@pytest.mark.parametrize("name", SIX)
def test_full_optimism_finds_the_optimum_whatever_the_model_says(name):
    problem = PlanningProblem(six(name), PARAMS)
    best = OptimalPlanner().solve(problem, scorer(None))
    for model in (_noisy_model(2, sd=0.3), TableCnn(lambda op: 0.5, lambda op: 0.0)):
        r = SearchPlanner(simulations=100_000, optimism=1.0, upper=0.0).solve(problem, scorer(model))
        assert r.robustness == pytest.approx(best.robustness)
        assert all(s.source in ("sim", "free") for s in r.steps)
        # a best-first search: it never needs every operation the optimum simulates
        assert r.stats["search_simulations"] < r.stats["operations"]
        assert check_plan(problem.assembly, r.steps) == []


def test_optimism_trades_simulations_for_robustness_monotonically_here():
    problem = PlanningProblem(six("triangles"), PARAMS)
    best = OptimalPlanner().solve(problem, scorer(None))
    runs = [SearchPlanner(simulations=100_000, optimism=u, upper=0.0).solve(problem, scorer(_noisy_model()))
            for u in (0.0, 0.5, 1.0)]
    sims = [r.stats["search_simulations"] for r in runs]
    assert sims[0] <= sims[1] <= sims[2]
    assert runs[2].robustness == pytest.approx(best.robustness)
    assert all(r.robustness <= best.robustness + 1e-12 for r in runs)
    # the plan's reported prediction is the plain one (simulated, else predicted), not raised
    assert runs[2].stats["predicted_robustness"] == pytest.approx(best.robustness)
    with pytest.raises(ValueError, match="optimism 1.5"):
        make_planner("search", optimism=1.5)


def test_a_spent_budget_under_optimism_chooses_by_what_is_known():
    # a perfect model: once the budget is spent, choosing by known scores is the optimum, while
    # the raised scores (unsimulated operations counted as 1) would pick almost anything
    problem = PlanningProblem(six("hexagon"), PARAMS)
    best = OptimalPlanner().solve(problem, scorer(None))
    perfect = TableCnn(lambda op: 0.5, score_fn=hash_score)
    r = SearchPlanner(simulations=3, optimism=1.0, upper=0.0).solve(problem, scorer(perfect))
    assert r.stats["refine_simulations"] == 3
    assert r.robustness == pytest.approx(best.robustness)
    assert r.stats["predicted_robustness"] == pytest.approx(best.robustness)


def test_the_beam_never_returns_a_plan_worse_than_simulator_only_greedy():
    """Beyond the exact budget, greedy's plan joins the final beam, so a model that misleads the
    beam (it predicts the opposite of the simulator) cannot make the search worse than greedy;
    and the case matters: the misled beam alone is worse than greedy on some assemblies."""
    from rap.plan.planners.greedy import SimPlanner
    from rap.plan.search.run import SearchRun
    from rap.plan.search.scores import SearchScores

    liar = TableCnn(lambda op: 0.5, score_fn=lambda op: 1.0 - hash_score(op))
    worse_alone = []
    for name in SIX:
        problem = PlanningProblem(six(name), PARAMS)
        greedy = SimPlanner().solve(problem, scorer(None))
        for options in (dict(simulations=0, upper=0.0), {}):  # the model alone; the shipped search
            found = SearchPlanner(max_operations=1, beam_width=2, **options).solve(
                problem, scorer(liar))
            assert found.stats["search"] == "beam"
            assert check_plan(problem.assembly, found.steps) == []
            assert found.robustness >= greedy.robustness, name
            assert found.stats["greedy_robustness"] == pytest.approx(greedy.robustness)
        alone = SearchPlanner(max_operations=1, beam_width=2, simulations=0, upper=0.0)
        s = scorer(liar)
        trees = alone._beam(SearchRun(problem, s, scores=SearchScores(problem, s)))  # no greedy
        worse_alone.append(float(np.prod(s.scores(problem, list(trees.values()))))
                           < greedy.robustness)
    assert any(worse_alone), worse_alone


def test_a_time_limit_stops_the_simulations_and_returns_the_best_known_plan():
    problem = PlanningProblem(six("triangles"), PARAMS)
    model = TableCnn(lambda op: 0.5, score_fn=lambda op: 0.5 * hash_score(op))  # underrates all
    free = SearchPlanner(simulations=400, upper=1.0).solve(problem, scorer(model))
    assert free.stats["search_simulations"] > 2
    # a limit already passed when the first round ends: one round of simulations, then a plan
    limited = SearchPlanner(simulations=400, upper=1.0, time_limit=1e-9).solve(problem,
                                                                              scorer(model))
    assert limited.status is PlanStatus.FOUND and check_plan(problem.assembly, limited.steps) == []
    assert limited.stats["stopped"] == "time"
    assert limited.stats["refine_simulations"] < free.stats["refine_simulations"]
    assert SearchPlanner().time_limit == 0.0  # the shipped search: no limit


def test_from_beam_from_parts_the_beam_plans_without_walking_the_graph(monkeypatch):
    import rap.plan.search.planner as planner_module

    problem = PlanningProblem(six("grid"), PARAMS)
    walked = []
    monkeypatch.setattr(planner_module, "reachable",
                        lambda *a, **k: walked.append(1) or pytest.fail("walked the graph"))
    r = SearchPlanner(beam_from=2).solve(problem, scorer(TableCnn(lambda op: 0.5,
                                                                  score_fn=hash_score)))
    assert r.status is PlanStatus.FOUND and r.stats["search"] == "beam" and not walked
    assert check_plan(problem.assembly, r.steps) == []
    assert SearchPlanner().beam_from == 30
