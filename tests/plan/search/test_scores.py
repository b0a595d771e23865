"""Search with conformal bounds: the bound with a perfect scorer is the optimum, it never falls
below a plan's own robustness, it covers the optimum when the bounds hold, --gap stops early and
says so, a settled choice short of the gap goes on by the bounds (phase 2) and never comes back
worse, and every plan passes the swept-area checker."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.commands._plan_output import bound_lines
from rap.model.calibration import ScoreBounds, fit
from rap.plan.dp import max_value
from rap.plan.scoring.cache import ScoreCache
from rap.plan.dp import dp_choice
from rap.plan.graph import reachable
from rap.plan.methods import SearchOptions, from_table_name
from rap.plan.planners.optimal import OptimalPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStatus
from rap.plan.scoring.scorer import Scorer
from rap.plan.search.planner import SearchPlanner
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams

from tests.plan.cases import SIX, six
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)
WIDTH = 0.2  # the under-prediction of ``low``: the simulator's score lies in [p, p + WIDTH]


#: the search of 0.2 and earlier when built without arguments: the model's scores alone
OLD = dict(simulations=0, upper=0.0)


def scorer(score_fn=hash_score):
    return Scorer(HashSim(), TableCnn(lambda op: 0.5, score_fn=score_fn), ScoreCache())


def tree(result):
    return [(s.moving, s.fixed, s.direction) for s in result.steps]


def optimum(problem):
    return OptimalPlanner().solve(problem, scorer())


def low(seed: int, width: float = WIDTH):
    """A model that under-predicts each operation by a fixed amount in [0, width] (seeded per
    operation key): the simulator's score lies in [p, p + width]."""
    def fn(op):
        u = np.random.default_rng([seed, int(op.key("low")[:12], 16)]).uniform(0.0, width)
        return max(0.0, hash_score(op) - u)
    return fn


def covering(width: float = WIDTH) -> ScoreBounds:
    """Bounds ``p + width`` at every level below 1000/1001: they hold for ``low``'s model."""
    return ScoreBounds((), ((width,) * 1000,))


def checked(problem, result):
    assert result.status is PlanStatus.FOUND
    assert check_plan(problem.assembly, result.steps) == []
    b = result.bound
    assert b is not None and b["robustness_upper"] >= result.robustness  # never below the plan
    assert b["gap"] == pytest.approx(1 - result.robustness / b["robustness_upper"])
    return b


@pytest.mark.parametrize("name", SIX)
def test_a_perfect_scorer_bounds_at_the_optimum_and_reaches_it(name):
    problem = PlanningProblem(six(name), PARAMS)
    best = optimum(problem)
    for planner in (SearchPlanner(bounds=ScoreBounds.zero_width(), simulations=0, upper=0.0),
                    SearchPlanner(bounds=ScoreBounds.zero_width(), upper=1.0, simulations=1000),
                    SearchPlanner(bounds=ScoreBounds.zero_width(), upper=0.35, simulations=200,
                                  gap=0.05)):
        found = planner.solve(problem, scorer())
        b = checked(problem, found)
        assert tree(found) == tree(best)
        assert b["robustness_upper"] == pytest.approx(best.robustness, rel=1e-12)
        assert b["gap"] == pytest.approx(0.0, abs=1e-12) and b["scope"] == "exact"
        assert "perfect" in b["note"] and b["confidence"] == 0.95


@pytest.mark.parametrize("name", ["hexagon", "rectilinear", "triangles"])
def test_branch_and_bound_on_trivial_bounds_is_exact(name):
    # every unsimulated operation bounded by 1: the search stops only when no sequence can beat
    # the best simulated one, so it returns the optimum's robustness whatever the model says
    problem = PlanningProblem(six(name), PARAMS)
    best = optimum(problem)
    found = SearchPlanner(bounds=ScoreBounds.trivial(), upper=1.0, simulations=10_000).solve(
        problem, scorer(low(3)))
    checked(problem, found)
    assert found.robustness == pytest.approx(best.robustness, rel=1e-12)
    assert found.stats["stopped"] in ("bound", "settled")
    assert found.stats["search_simulations"] <= best.stats["operations"]


@pytest.mark.parametrize("seed", range(6))
def test_the_bound_never_falls_below_the_plan_and_covers_the_optimum(seed):
    rng = np.random.default_rng(seed)
    name = SIX[seed % len(SIX)]
    problem = PlanningProblem(six(name), PARAMS)
    best = optimum(problem)
    loose = fit(rng.uniform(0, 1, 300), rng.uniform(0, 1, 300), bins=3)  # a fit, not a cover
    for bounds in (covering(), loose, ScoreBounds.trivial()):
        for options in (dict(), dict(simulations=int(rng.integers(1, 30)), upper=1.0),
                        dict(simulations=20, optimism=0.3, gap=0.1),
                        dict(simulations=15, upper=0.5, trust=0.9),
                        dict(simulations=40, upper=1.0, gap=0.0),
                        dict(simulations=60, upper=0.35, gap=0.05),
                        dict(simulations=int(rng.integers(1, 40)), upper=0.35, trust=0.8,
                             gap=0.1)):
            found = SearchPlanner(bounds=bounds, **{**OLD, **options}).solve(problem, scorer(low(seed)))
            b = checked(problem, found)
            assert found.robustness <= best.robustness * (1 + 1e-12)
            if bounds is not loose:  # bounds that hold: the optimum lies under V
                assert b["robustness_upper"] >= best.robustness * (1 - 1e-12)


def test_gap_stops_early_and_says_so():
    problem = PlanningProblem(six("mixed-square"), PARAMS)
    best = optimum(problem)
    width = 0.2
    runs = {}
    for gap in (None, 0.1):
        runs[gap] = SearchPlanner(bounds=covering(width), upper=1.0, simulations=10_000,
                                  gap=gap).solve(problem, scorer(low(1, width)))
        checked(problem, runs[gap])
    full, early = runs[None], runs[0.1]
    assert full.robustness == pytest.approx(best.robustness, rel=1e-12)  # bounds hold: exact
    assert early.stats["stopped"] == "gap" and early.stats["gap"] == 0.1
    n = early.stats["stopped_after"]
    assert n < full.stats["search_simulations"] and early.stats["search_simulations"] == n
    assert early.robustness >= 0.9 * best.robustness  # within the gap of the optimum
    assert early.bound["gap"] <= 0.1 + 1e-12  # the bound holds, so its final gap is smaller
    lines = bound_lines(early)
    assert lines[0].startswith(f"optimum <= {early.bound['robustness_upper']:.4f} at 95% "
                               f"confidence: this plan has at least "
                               f"{100 * (1 - early.bound['gap']):.1f}% of the optimum's")
    assert lines[1] == f"stopped at --gap 0.1 after {n} simulations"
    assert "stopped" not in " ".join(bound_lines(SearchPlanner(bounds=covering(), simulations=0, upper=0.0).solve(
        problem, scorer(low(1)))))


def test_beam_bounds_only_its_sequences():
    gen = pytest.importorskip("rap.geometry.families.simple")
    asm = gen.random_tiling(10, np.random.default_rng(5))
    problem = PlanningProblem(asm, PARAMS)
    found = SearchPlanner(beam_width=3, max_operations=50, bounds=covering(), upper=1.0,
                          simulations=30, gap=0.05).solve(problem, scorer(low(2)))
    b = checked(problem, found)
    assert found.stats["search"] == "beam" and b["scope"] == "beam"
    assert "final beam" in b["note"]


def test_max_value_is_the_dynamic_programme():
    rng = np.random.default_rng(4)
    for name in SIX:
        problem = PlanningProblem(six(name), PARAMS)
        graph = reachable(problem)
        table = {s: list(rng.uniform(0, 1, len(c)) * (rng.uniform(0, 1, len(c)) > 0.2))
                 for s, c in graph.items()}
        best, _ = dp_choice(graph, table)
        assert max_value(graph, table.__getitem__, problem.whole) == pytest.approx(
            best[problem.whole], rel=1e-12)
        ones = {s: [1.0] * len(c) for s, c in graph.items()}
        assert max_value(graph, ones.__getitem__, problem.whole) == 1.0


def test_kept_tables_give_what_a_fresh_dynamic_programme_gives():
    # the search keeps its DP tables between rounds and drops those above changed scores
    from rap.plan.search.scores import SearchScores, incumbent
    from rap.plan.dp import dp_choice_bounded
    rng = np.random.default_rng(8)
    for name in ("triangles", "grid"):
        problem = PlanningProblem(six(name), PARAMS)
        graph = reachable(problem)
        sc = SearchScores(problem, scorer(low(3)), covering(), 0.99, upper=0.5)
        ops = [op for c in graph.values() for op in c]
        for step in range(12):
            if step == 9:
                sc.lower()
            for view, memo in (("of", sc.memo("of")), ("of", None), ("high", None)):
                def listed(s, view=view):
                    sc.predict(graph[s])
                    return sc.scores(view, s, graph[s]) if memo else [
                        getattr(sc, view)(op) for op in graph[s]]
                if view == "high":
                    fresh = max_value(graph, listed, problem.whole)
                    assert max_value(graph, lambda s: sc.scores("high", s, graph[s]),
                                     problem.whole, sc.memo("high")) == fresh
                elif memo:
                    kept = dp_choice_bounded(graph, listed, problem.whole, memo)
                else:
                    assert dp_choice_bounded(graph, listed, problem.whole) == kept
            got = incumbent(graph, sc, problem.whole)
            alone = dp_choice_bounded(graph, lambda s: [sc.simulated_or_0(op) for op in graph[s]],
                                      problem.whole)
            assert got[0] == alone[0] and (got[1] is None or got[1] == {
                s: op for s, (_, op) in alone[1].items()})
            sc.simulate([ops[i] for i in rng.choice(len(ops), 3, replace=False)] +
                        [op for _, op in kept[1].values()][:2])


def test_without_simulations_upper_optimism_and_gap_change_nothing():
    gen = pytest.importorskip("rap.geometry.families.simple")
    beam = PlanningProblem(gen.random_tiling(10, np.random.default_rng(5)), PARAMS)
    for problem, extra in ((PlanningProblem(six("triangles"), PARAMS), {}),
                           (beam, dict(beam_width=3, max_operations=50))):
        plain = SearchPlanner(bounds=covering(), simulations=0, **extra).solve(problem, scorer(low(1)))
        for opts in (dict(upper=0.35, gap=0.05), dict(optimism=0.5, upper=1.0, gap=0.2)):
            got = SearchPlanner(bounds=covering(), simulations=0, **extra, **opts).solve(problem,
                                                                           scorer(low(1)))
            assert tree(got) == tree(plain) and got.stats["search_simulations"] == 0
            assert got.stats["predicted_operations"] == plain.stats["predicted_operations"]


def test_options_names_and_json():
    opts = from_table_name("search-s100-u100-c90-g10")
    assert (opts.simulations, opts.upper, opts.confidence, opts.gap) == (100, 1.0, 0.9, 0.1)
    assert opts.table_name() == "search-s100-u100-c90-g10"
    assert SearchOptions().table_name() == "search" and SearchOptions().gap == 0.0
    assert from_table_name("search-s200-u35-c95") == SearchOptions()  # the defaults (no gap)
    assert from_table_name("search-s200-u35-c95-g5") == SearchOptions(gap=0.05)
    planner = opts.build()
    assert (planner.upper, planner.confidence, planner.gap) == (1.0, 0.9, 0.1)
    problem = PlanningProblem(six("hexagon"), PARAMS)
    found = SearchPlanner(bounds=covering(), confidence=0.9, simulations=0, upper=0.0).solve(problem, scorer(low(0)))
    doc = found.to_json()
    assert doc["bound"]["confidence"] == 0.9 and doc["bound"]["scope"] == "exact"
    assert PlanResult.from_json(doc).to_json() == doc
    plain = OptimalPlanner().solve(problem, scorer())
    assert plain.bound is None and "bound" not in plain.to_json() and bound_lines(plain) == []
    # the per-step level: Bonferroni over the n - 1 steps
    n = len(problem.whole)
    assert f"level {1 - 0.1 / (n - 1):.4g}" in SearchPlanner(
        bounds=fit([0.5] * 500, [0.6] * 500), confidence=0.9, simulations=0, upper=0.0).solve(
        problem, scorer(low(0))).bound["note"]
    assert math.isclose(found.bound["robustness_upper"],
                        max(found.bound["robustness_upper"], found.robustness))


def test_bounds_simulate_a_few_operations_a_round_most_raised_first():
    problem = PlanningProblem(six("triangles"), PARAMS)
    for per_round in (1, 2):
        s = scorer(low(5))
        found = SearchPlanner(bounds=covering(), upper=1.0, simulations=6,
                              bound_round=per_round).solve(problem, s)
        checked(problem, found)
        assert found.stats["refine_simulations"] == 6 and found.stats["stopped"] == "budget"
        assert s.simulator.calls >= 6 // per_round  # rounds of at most per_round (+ evaluation)


def p1_and_p2(problem, model, **options):
    """The same search stopped when its choice settles (no ``gap``: phase 1 alone) and with
    phase 2 (module doc of ``rap.plan.search.planner``, 5)."""
    return [SearchPlanner(bounds=covering(), **{**OLD, **options, "gap": g}).solve(problem, scorer(model))
            for g in (None, options.get("gap"))]


def test_a_settled_choice_short_of_the_gap_goes_on_until_within_it_and_says_so():
    problem = PlanningProblem(six("mixed-square"), PARAMS)
    best = optimum(problem)
    p1, p2 = p1_and_p2(problem, low(1), upper=0.0, simulations=400, gap=0.05)
    for r in (p1, p2):
        checked(problem, r)
    # phase 1 alone: the model's choice, simulated, settles far from the bound
    assert p1.stats["stopped"] == "settled" and p1.bound["gap"] > 0.05
    assert "phase2_simulations" not in p1.stats
    # phase 2: the same phase 1, then simulations by the bounds until within the gap
    n1, n2 = p2.stats["phase1_simulations"], p2.stats["phase2_simulations"]
    assert n1 == p1.stats["search_simulations"] and n2 > 0
    assert p2.stats["stopped"] == "gap" and p2.stats["gap"] == 0.05
    assert p2.stats["stopped_after"] == n1 + n2 == p2.stats["search_simulations"]
    assert p2.robustness >= (1 - 0.05) * p2.stats["search_bound"]
    assert p2.bound["gap"] <= 0.05 + 1e-12 and p2.robustness > p1.robustness
    assert p2.robustness >= 0.95 * best.robustness  # the bounds hold: within the gap of it
    assert p2.stats["predicted_robustness"] == pytest.approx(p2.robustness, rel=1e-12)
    assert bound_lines(p2)[1] == f"stopped at --gap 0.05 after {n1 + n2} simulations"
    # the budget spent first: the best fully simulated sequence, and the table says so
    short = SearchPlanner(bounds=covering(), upper=0.0, simulations=n1 + 3, gap=0.05).solve(
        problem, scorer(low(1)))
    checked(problem, short)
    assert short.stats["stopped"] == "budget" and short.stats["phase2_simulations"] == 3
    assert short.robustness >= p1.robustness
    assert bound_lines(short)[1] == (f"the budget ran out after {n1 + 3} simulations, 3 of them "
                                     f"after the choice settled, before --gap 0.05 was reached")


@pytest.mark.parametrize("name", SIX)
def test_phase_two_never_returns_a_worse_plan_than_the_settled_choice(name):
    problem = PlanningProblem(six(name), PARAMS)
    ran = 0
    for seed in range(3):
        for options in (dict(upper=0.0), dict(upper=0.35), dict(upper=0.35, trust=0.8)):
            for budget in (12, 400):
                p1, p2 = p1_and_p2(problem, low(seed), simulations=budget, gap=0.05, **options)
                checked(problem, p2)
                if "phase2_simulations" not in p2.stats:  # phase 1 reached the gap or the budget
                    assert tree(p2) == tree(p1) and all(p2.stats[k] == p1.stats[k] for k in (
                        "stopped", "search_simulations", "predicted_robustness"))
                    continue
                ran += 1
                assert p2.stats["phase1_simulations"] == p1.stats["search_simulations"]
                # by what is known of each plan: the settled choice's known robustness at least
                assert p2.stats["predicted_robustness"] >= p1.stats["predicted_robustness"]
                if "trust" not in options:  # both fully simulated: their robustness too
                    assert p2.robustness >= p1.robustness
    assert ran >= 9


def test_phase_two_keeps_the_settled_choice_when_nothing_better_is_simulated():
    # everything trusted: phase 1 settles at once with nothing simulated; two simulations
    # cannot complete a sequence, so the settled choice is kept
    problem = PlanningProblem(six("triangles"), PARAMS)
    p1, p2 = p1_and_p2(problem, low(2), trust=0.01, simulations=2, gap=0.05)
    checked(problem, p2)
    assert p1.stats["search_simulations"] == 0 and p1.stats["stopped"] == "settled"
    assert p2.stats["stopped"] == "budget" and p2.stats["phase2_simulations"] == 2
    assert tree(p2) == tree(p1)


def test_beam_phase_two_over_the_final_beam():
    gen = pytest.importorskip("rap.geometry.families.simple")
    problem = PlanningProblem(gen.random_tiling(10, np.random.default_rng(6)), PARAMS)
    p1, p2 = p1_and_p2(problem, low(0), beam_width=3, max_operations=50, upper=0.35,
                       simulations=60, gap=0.05)
    b = checked(problem, p2)
    assert p2.stats["search"] == "beam" and b["scope"] == "beam"
    assert p1.stats["stopped"] == "settled" and p1.bound["gap"] > 0.05
    assert p2.stats["phase2_simulations"] > 0 and p2.stats["stopped"] in ("gap", "bound")
    assert p2.robustness >= p1.robustness and b["gap"] <= 0.05 + 1e-12
