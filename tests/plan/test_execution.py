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
