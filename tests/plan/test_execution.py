"""The plan as it executes (rap.plan.execution): the choice among the search's plans by measured
sequence success, and the format-3 report of the front door."""

from __future__ import annotations

from rap.execution.rollout import ChunkOutcome
from rap.execution.sequence import measure
from rap.operation import Operation
from rap.plan.execution import ExecutionOptions, choose, rollout_plan
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
from rap.sim.params import SimParams

from tests.execution.cases import ROOT, slot

ARCH = ROOT / "assemblies" / "cells" / "arch.json"


class ByPlan:
    """A runner whose rollouts of plan ``i`` (told apart by its step's direction) succeed with
    the rate ``rates[i]`` (rollout j fails when its index falls in the rate's complement)."""

    def __init__(self, rates):
        self.rates = rates

    def run_rollouts(self, assembly, plan, root_seed, work):
        r = self.rates[round(plan.steps[0].direction[0] * 10)]
        return [ChunkOutcome(f, tuple(-1 if ((f + k) * 0.6180339887) % 1 < r else 0
                                      for k in range(c))) for f, c in work]


def _plans(n):
    asm, _ = slot(1)
    problem = PlanningProblem(asm, SimParams(), 0)
    plans = [PlanResult(PlanStatus.FOUND, "search", "slot", (PlanStep.of(
        Operation(frozenset({"peg"}), frozenset({"base"}), (i / 10, -1.0)), "sim", score=0.9),),
        0.9) for i in range(n)]
    return problem, plans


def test_an_alternative_is_chosen_only_when_measured_better_beyond_noise():
    problem, plans = _plans(3)
    opts = ExecutionOptions()
    chosen, outcomes = choose(problem, plans, ByPlan([0.4, 0.9, 0.5]), opts, 0)
    assert chosen == 1
    chosen, _ = choose(problem, plans, ByPlan([0.6, 0.62, 0.58]), opts, 0)
    assert chosen == 0  # a hair better is noise: the search's plan stays
    chosen, outcomes = choose(problem, plans, ByPlan([0.9, 0.3, 0.2]), opts, 0)
    assert chosen == 0 and [sum(len(o.failed_at) for o in outs) for outs in outcomes] == [100] * 3
    # nothing left to beat the search's plan after the first wave: the choice stops there


def test_a_close_call_is_measured_on_until_it_is_decided():
    """An alternative 0.06 above the search's plan is not beyond its interval at 200 rollouts:
    the two are measured on (400 each) and it is chosen; 0.02 above is not a close call."""
    problem, plans = _plans(3)
    opts = ExecutionOptions()
    chosen, outcomes = choose(problem, plans, ByPlan([0.70, 0.76, 0.2]), opts, 0)
    runs = [sum(len(o.failed_at) for o in outs) for outs in outcomes]
    assert chosen == 1 and runs == [400, 400, 100]
    chosen, outcomes = choose(problem, plans, ByPlan([0.70, 0.72, 0.2]), opts, 0)
    assert chosen == 0 and [sum(len(o.failed_at) for o in outs) for outs in outcomes] == \
        [200, 200, 100]
    chosen, outcomes = choose(problem, plans, ByPlan([0.70, 0.735, 0.2]), opts, 0)
    assert max(sum(len(o.failed_at) for o in outs) for outs in outcomes) == 800


def test_the_default_chooses_by_sequence_success_and_never_worse_than_the_product():
    from rap.io import load_assembly
    from rap.plan import plan
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.seeds import DEFAULT_ROOT_SEED

    opts = ExecutionOptions(mm_per_unit=2.0, tolerances=False)
    sim = LocalSimulator(processes=2)
    try:
        chosen = plan(ARCH, seed=DEFAULT_ROOT_SEED, simulator=sim, execution=opts,
                      alternatives=3)
        product = plan(ARCH, seed=DEFAULT_ROOT_SEED, simulator=sim, execution=opts)
        problem = PlanningProblem(load_assembly(ARCH), SimParams(), DEFAULT_ROOT_SEED)
        again = [measure(problem.assembly, rollout_plan(problem, p, opts), sim, 77,
                         rollouts=200).success for p in (chosen, product)]
    finally:
        sim.close()
    seq = chosen.sequence
    assert seq.chosen_by == "sequence success" and len(seq.candidates) == 4
    assert product.sequence.chosen_by == "product" and not product.sequence.candidates
    assert again[0].high >= again[1].low  # never measured worse beyond the intervals
    doc = chosen.to_json()
    assert doc["format"] == 3 and doc["sequence_success"]["rollouts"] >= 100
    assert all(s["execution"]["reached"] is not None for s in doc["steps"])
    assert PlanResult.from_json(doc).to_json() == doc


def test_the_perturbed_candidate_is_the_best_plan_on_perturbed_start_scores(monkeypatch):
    """The candidate is the optimal DP's plan on ``perturbed_successes`` of every operation that
    is not free (the same counts on the workers as here), a complete plan in assembly order with
    R unknown; past the operation limit there is none; ``plan`` offers it to the choice."""
    from rap.execution.perturbed import perturbed_successes
    from rap.io import load_assembly
    from rap.plan import execution as ex
    from rap.plan import plan
    from rap.plan.dp import dp_choice
    from rap.plan.graph import reachable
    from rap.plan.report.result import is_assembly_order
    from rap.plan.scoring.local_simulator import LocalSimulator

    problem = PlanningProblem(load_assembly(ARCH), SimParams(trials=20), 5)
    opts = ExecutionOptions(mm_per_unit=2.0, tolerances=False, perturbed=True)
    template = PlanResult(PlanStatus.FOUND, "search", "arch", robustness=0.5)
    found = ex.perturbed_candidate(problem, template, None, opts)
    here, simulated = found.plan, found.simulated
    sim = LocalSimulator(processes=2)
    try:
        on_workers = ex.perturbed_candidate(problem, template, sim, opts).plan
        planned = plan(problem, simulator=sim, execution=opts, alternatives=1)
    finally:
        sim.close()
    assert here is not None and here.steps == on_workers.steps and here.robustness is None
    assert here.stats["perturbed_starts"] and simulated > 0
    assert is_assembly_order(here.steps, problem.assembly.ids) is None
    graph = reachable(problem)
    score = {problem.key(op): 1.0 if problem.is_free(op) else perturbed_successes(
        problem.assembly, op, problem.params, opts.errors, 2.0, problem.seed(op)) / 20
        for ops in graph.values() for op in ops}
    best, _ = dp_choice(graph, {s: [score[problem.key(op)] for op in ops]
                                for s, ops in graph.items()})
    product = 1.0
    for s in here.steps:
        product *= score[problem.key(s.to_operation())]
    assert product == best[problem.whole]  # the DP's best product of perturbed scores
    flagged = [c for c in planned.sequence.candidates if c.get("perturbed_starts")]
    assert len(planned.sequence.candidates) in (2, 3) and len(flagged) <= 1
    assert len(flagged) == len(planned.sequence.candidates) - 2  # offered unless a duplicate
    assert planned.stats["perturbed_simulated"] == simulated
    assert planned.stats["perturbed_outcome"] == ("offered" if flagged else "duplicate")
    monkeypatch.setattr(ex, "PERTURBED_MAX_OPERATIONS", 3)
    assert ex.perturbed_candidate(problem, template, None, opts) == ex.PerturbedCandidate(
        None, 0, too_large=True)



def test_perturbed_counts_are_kept_in_the_score_cache_under_their_own_keys():
    """A second candidate on the same cache simulates nothing and finds the same plan; the
    counts' keys are never exact-start keys, and another scale of errors gets other keys."""
    from dataclasses import replace

    from rap.io import load_assembly
    from rap.plan import execution as ex
    from rap.plan.graph import reachable
    from rap.plan.scoring.cache import ScoreCache

    problem = PlanningProblem(load_assembly(ARCH), SimParams(trials=20), 5)
    opts = ExecutionOptions(mm_per_unit=2.0, tolerances=False, perturbed=True)
    template = PlanResult(PlanStatus.FOUND, "search", "arch", robustness=0.5)
    cache = ScoreCache()
    first = ex.perturbed_candidate(problem, template, None, opts, cache)
    again = ex.perturbed_candidate(problem, template, None, opts, cache)
    assert first.simulated == len(cache) > 0 and again.simulated == 0
    assert (first.cached, again.cached) == (0, first.simulated)
    assert again.plan is not None and again.plan.steps == first.plan.steps
    exact = {problem.key(op) for ops in reachable(problem).values() for op in ops}
    assert not exact & {k for k, _ in cache.items()}
    other = ex.perturbed_candidate(problem, template, None, replace(opts, mm_per_unit=1.0), cache)
    assert other.simulated == first.simulated and len(cache) == 2 * first.simulated

def test_the_perturbed_candidate_stops_at_its_budget_and_a_rerun_goes_on_from_the_cache(
        monkeypatch):
    """Past ``max_simulations`` nothing is simulated; past ``perturbed_seconds`` the batch under
    way finishes and the candidate is not offered, its counts kept; a rerun simulates the rest
    and finds the plan of an unbounded run."""
    from dataclasses import replace

    from rap.io import load_assembly
    from rap.plan import execution as ex
    from rap.plan.scoring.cache import ScoreCache

    problem = PlanningProblem(load_assembly(ARCH), SimParams(trials=20), 5)
    opts = ExecutionOptions(mm_per_unit=2.0, tolerances=False, perturbed=True)
    template = PlanResult(PlanStatus.FOUND, "search", "arch", robustness=0.5)
    whole = ex.perturbed_candidate(problem, template, None, opts)
    n = whole.simulated
    assert ex.perturbed_candidate(problem, template, None, opts, None, n - 1) == \
        ex.PerturbedCandidate(None, 0, over_budget=True)
    monkeypatch.setattr(ex, "PERTURBED_CHECK_EVERY", 5)
    cache = ScoreCache()
    cut = ex.perturbed_candidate(problem, template, None, replace(opts, perturbed_seconds=0.0),
                                 cache)
    assert cut.over_budget and cut.plan is None and cut.simulated == 5 == len(cache)
    rest = ex.perturbed_candidate(problem, template, None, opts, cache, n - 5)
    assert (rest.simulated, rest.cached) == (n - 5, 5) and rest.plan.steps == whole.plan.steps
