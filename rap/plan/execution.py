"""A found plan as it will execute: sequence success under the cell's errors, each step's
success once reached, clearance and tolerance; and the choice among the search's best plans by
what they measure.

``execute_report(problem, result, runner, options, candidates=())``:

1. **Choice** (when ``candidates``, other complete plans of the search, are given): every plan,
   the search's own first, is measured by rollouts (``rap.execution.sequence``) on the **same**
   seeds (common random numbers), in waves of ``CHOICE_WAVES`` (100, then 200 rollouts each);
   after a wave a plan whose interval lies wholly below the leader's is dropped, and so is an
   alternative that measures no better than the search's plan. A **close call** (an alternative
   measured at least ``CLOSE_LEAD`` = 0.03 above the search's plan, but not beyond its interval)
   is measured on, the leading alternative and the search's plan alone, to ``CLOSE_WAVES`` (400,
   then 800 rollouts each) until it is decided. An alternative
   is chosen only when its interval lies wholly above the search's plan's measured success (the
   best such); else the search's plan stays. The search's plan is dropped only when measured
   worse beyond both intervals, so the chosen plan is never measured worse than it beyond their
   intervals, and a plan is not swapped for another on noise.
2. **Measurement**: the chosen plan's ``sequence_success``, in waves until its interval is within
   ``half_width`` (``rap.execution.sequence.measure``): the search's plan goes on from its
   rollouts; a chosen alternative is measured again on fresh seeds (the best of several
   estimates is biased upward; the figure a plan reports must not be).
3. **Steps**: per step the rollouts that reached it and its success once reached, its clearance
   (``rap.execution.clearance``, exact) and tolerance (``rap.execution.tolerance``, simulated;
   ``options.tolerances``), flagged ``below_budget`` where the tolerance is below the cell's
   error budget across the insertion.

**The perturbed candidate** (``options.perturbed``; ``rap-farm plan --perturbed-candidate``):
``perturbed_candidate`` adds to the candidates the best product of perturbed-start scores over the
AND/OR graph (``rap.execution.perturbed``: every operation that is not free simulated once with
its fixed parts displaced as rollouts leave them), a plan R may rank far down where a tight
insertion meets parts placed loosely before it: on a 7-part pegs assembly it is R's 974th of
1,142 sequences and executes 2x R's best (docs/ROBOT.md, "The best of all sequences"). The
choice judges it as any other. Cost: one simulation of every operation (an optimum's), up to
``PERTURBED_MAX_OPERATIONS``.

An alternative that is chosen has its unsimulated steps simulated (``evaluate_steps``) so that
its R is known, like every plan's. Cost: the rollouts (a wave of 100 rollouts of an n-step plan is
about ``4 n`` operations' labelling) per candidate still running, plus the tolerances (about three
operations' labelling per step with something across).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from rap.execution.clearance import clearance
from rap.execution.error_model import DEFAULT_ERRORS, ErrorModel
from rap.execution.rollout import ChunkOutcome, RolloutPlan, chunks
from rap.execution.sequence import HALF_WIDTH, WAVES, InProcess, RolloutRunner, measure, tally
from rap.execution.tolerance import ToleranceRunner, tolerance
from rap.plan.problem import PlanningProblem
from rap.plan.report.execution import SequenceReport, StepExecution
from rap.plan.report.result import PlanResult
from rap.stats import rate

__all__ = ["ExecutionOptions", "execute_report", "choose", "rollout_plan", "CHOICE_WAVES",
           "CLOSE_WAVES", "CLOSE_LEAD",
           "perturbed_candidate", "PerturbedCandidate", "PERTURBED_MAX_OPERATIONS",
           "PERTURBED_CHECK_EVERY"]

CHOICE_WAVES = (100, 200)  # rollouts of each candidate while choosing
#: a close call: after CHOICE_WAVES, an alternative measured at least CLOSE_LEAD above the search's
#: plan but not beyond its interval is measured on with the search's plan, to these rollouts
CLOSE_WAVES, CLOSE_LEAD = (400, 800), 0.03


@dataclass(frozen=True)
class ExecutionOptions:
    """How a plan's execution is measured: the cell's ``errors`` and ``mm_per_unit`` (the
    assembly's unit in mm), the interval's target ``half_width``, at most ``max_rollouts`` per
    plan, the ``tolerances`` of the steps (simulated) or not, ``carry`` (False: each step from
    the exact placement, R's assumption), ``perturbed`` (the choice also measures the best plan
    on perturbed-start scores, ``perturbed_candidate``) and ``perturbed_seconds`` (the most its
    simulations may take; None: no limit)."""

    errors: ErrorModel = DEFAULT_ERRORS
    mm_per_unit: float = 1.0
    half_width: float = HALF_WIDTH
    max_rollouts: int = WAVES[-1]
    tolerances: bool = True
    carry: bool = True
    perturbed: bool = False
    perturbed_seconds: float | None = None


#: the perturbed candidate is built for graphs of at most this many operations (each one simulated
#: once from a perturbed start: about 0.15 s a core per operation)
PERTURBED_MAX_OPERATIONS = 3000
PERTURBED_CHECK_EVERY = 64  # operations simulated between two looks at ``perturbed_seconds``


@dataclass(frozen=True)
class PerturbedCandidate:
    """What ``perturbed_candidate`` found: ``plan`` (None past the operation limit,
    ``too_large``, or where no sequence has a positive score), ``simulated``, the operations it
    simulated, and ``cached``, those whose counts the cache held; ``over_budget``: not finished
    within the simulations or the seconds allowed (what was simulated is in the cache)."""

    plan: PlanResult | None
    simulated: int
    too_large: bool = False
    cached: int = 0
    over_budget: bool = False


def perturbed_candidate(problem: PlanningProblem, template: PlanResult, runner,
                        options: ExecutionOptions, cache=None,
                        max_simulations: int | None = None) -> PerturbedCandidate:
    """The best product of perturbed-start scores (``rap.execution.perturbed``) over the problem's
    AND/OR graph, as a plan for the choice: ``template`` (the search's plan) with its steps, R
    unknown (simulated if chosen). Every operation that is not free is simulated once from a
    perturbed start (``runner.run_perturbed`` where the runner has workers, else here), unless
    ``cache`` (a ``ScoreCache``) holds its count (``rap.execution.perturbed.perturbed_key``); the
    counts simulated are added to it. Nothing is simulated past ``PERTURBED_MAX_OPERATIONS``, nor
    when more than ``max_simulations`` would be; with ``options.perturbed_seconds`` the
    simulations go in batches of ``PERTURBED_CHECK_EVERY`` and stop once that time is spent (a
    service's request budget: a later request goes on from the cache)."""
    from rap.execution.perturbed import PerturbedRunner, perturbed_key, perturbed_successes
    from rap.plan.scoring.cache import CachedScore
    from rap.plan.dp import dp_choice, dp_tree
    from rap.plan.graph import TooLarge, assembly_order, reachable
    from rap.plan.report.result import PlanStep

    try:
        graph = reachable(problem, PERTURBED_MAX_OPERATIONS)
    except TooLarge:
        return PerturbedCandidate(None, 0, too_large=True)
    asm, params = problem.assembly, problem.params
    todo = {}
    for ops in graph.values():
        for op in ops:
            if not problem.is_free(op):
                todo.setdefault(problem.key(op), op)
    pkey = {k: perturbed_key(k, options.errors, options.mm_per_unit) for k in todo}
    known = dict(zip(todo, cache.get_many(pkey[k] for k in todo))) if cache is not None else {}
    score = {k: hit.score for k, hit in known.items() if hit is not None}
    missing = [k for k in todo if k not in score]
    jobs = [(asm, todo[k], params, options.errors, options.mm_per_unit, problem.seed(todo[k]))
            for k in missing]
    cached = len(todo) - len(jobs)
    if max_simulations is not None and len(jobs) > max_simulations:
        return PerturbedCandidate(None, 0, cached=cached, over_budget=True)
    limit, t0 = options.perturbed_seconds, time.perf_counter()
    step = len(jobs) if limit is None else PERTURBED_CHECK_EVERY
    for i in range(0, len(jobs), max(1, step)):
        if limit is not None and i and time.perf_counter() - t0 > limit:
            return PerturbedCandidate(None, i, cached=cached, over_budget=True)
        batch, keys = jobs[i:i + step], missing[i:i + step]
        wins = (runner.run_perturbed(batch) if isinstance(runner, PerturbedRunner)
                else [perturbed_successes(*j) for j in batch])
        score.update((k, w / params.trials) for k, w in zip(keys, wins))
        if cache is not None:
            cache.put_many((pkey[k], CachedScore(w / params.trials, int(w), params.trials))
                           for k, w in zip(keys, wins))
    score_of = {s: [score.get(problem.key(op), 1.0) for op in ops] for s, ops in graph.items()}
    best, arg = dp_choice(graph, score_of)
    if not best.get(problem.whole, 0.0) > 0.0:
        return PerturbedCandidate(None, len(jobs), cached=cached)
    choice = {sub: PlanStep.of(op, "sim") for sub, (_, op) in
              dp_tree(graph, arg, problem.whole).items()}
    plan = replace(template, steps=tuple(assembly_order(choice, problem.whole)), robustness=None,
                   stats={"perturbed_starts": True})
    return PerturbedCandidate(plan, len(jobs), cached=cached)


def rollout_plan(problem: PlanningProblem, result: PlanResult,
                 options: ExecutionOptions) -> RolloutPlan:
    return RolloutPlan(tuple(s.to_operation() for s in result.steps), problem.params,
                       options.errors, options.mm_per_unit, options.carry)


def _waves(options: ExecutionOptions) -> tuple[int, ...]:
    return tuple(w for w in WAVES if w < options.max_rollouts) + (int(options.max_rollouts),)


def choose(problem: PlanningProblem, plans: Sequence[PlanResult], runner: RolloutRunner,
           options: ExecutionOptions, seed: int,
           on_progress: Callable[[str], None] | None = None
           ) -> tuple[int, list[list[ChunkOutcome]]]:
    """(the index of the plan chosen, each plan's rollout outcomes) by the rule of the module doc,
    step 1. ``plans[0]`` is the search's plan."""
    rplans = [rollout_plan(problem, p, options) for p in plans]
    outcomes: list[list[ChunkOutcome]] = [[] for _ in plans]
    done = [0] * len(plans)
    alive = list(range(len(plans)))
    asm = problem.assembly
    rates = {}
    for target in CHOICE_WAVES:
        for i in alive:
            outcomes[i] += runner.run_rollouts(asm, rplans[i], seed, chunks(done[i], target))
            done[i] = target
            rates[i] = rate(*_wins_runs(rplans[i], outcomes[i]))
        lead = max(alive, key=lambda i: (rates[i].value, -i))
        # an alternative stays while it may still beat the search's plan; that plan stays
        # unless measured worse than the leader beyond both intervals
        alive = [i for i in alive if rates[i].high >= rates[lead].low
                 and (i == 0 or rates[i].value > rates[0].value)]
        if on_progress is not None:
            on_progress(f"rollouts: {target} of each plan, {len(alive)} still in the running")
        if len(alive) == 1:
            break
    for target in CLOSE_WAVES:  # a close call: the leading alternative and the search's plan
        if any(i and rates[i].low > rates[0].value for i in alive):
            break  # decided
        close = [i for i in alive if i and rates[i].value >= rates[0].value + CLOSE_LEAD]
        if not close:
            break
        alive = [0, max(close, key=lambda i: (rates[i].value, -i))]
        for i in alive:
            outcomes[i] += runner.run_rollouts(asm, rplans[i], seed, chunks(done[i], target))
            done[i] = target
            rates[i] = rate(*_wins_runs(rplans[i], outcomes[i]))
        if on_progress is not None:
            on_progress(f"rollouts: {target} of the search's plan and its closest rival")
    better = [i for i in alive if i and rates[i].low > rates[0].value]
    chosen = max(better, key=lambda i: (rates[i].value, -i)) if better else 0
    return chosen, outcomes


def _candidate(plan: PlanResult, rplan: RolloutPlan, outcomes, chosen: bool) -> dict:
    r = rate(*_wins_runs(rplan, outcomes))
    out = {"robustness": plan.robustness, "rate": r.value, "interval": [r.low, r.high],
           "rollouts": r.trials, "chosen": chosen}
    if plan.stats.get("perturbed_starts"):
        out["perturbed_starts"] = True  # the best plan on perturbed-start scores
    return out


def _wins_runs(plan: RolloutPlan, outcomes: list[ChunkOutcome]) -> tuple[int, int]:
    wins, _, _, runs = tally(len(plan.steps), outcomes)
    return wins, runs


def _step_executions(problem: PlanningProblem, result: PlanResult, m,
                     options: ExecutionOptions, seed: int, runner) -> tuple:
    out = []
    budget = options.errors.budget_across_mm
    ops = [s.to_operation() for s in result.steps]
    gaps = [clearance(problem.assembly, op) for op in ops]
    tols = [None] * len(ops)
    if options.tolerances:  # the steps in parallel where the runner can (local workers, the pool)
        jobs = [(problem.assembly, op, problem.params, options.mm_per_unit, seed, problem.key(op),
                 c is None or problem.is_free(op)) for op, c in zip(ops, gaps)]
        tols = (runner.run_tolerances(jobs) if isinstance(runner, ToleranceRunner)
                else [tolerance(*j) for j in jobs])
    for k, (op, c, tol) in enumerate(zip(ops, gaps, tols)):
        reached = m.step_rate(k)
        out.append(StepExecution(
            reached=m.step_tried[k], interval=None if reached is None else (reached.low, reached.high),
            success_when_reached=None if reached is None else reached.value,
            clearance_mm=None if c is None else round(c * options.mm_per_unit, 6),
            tolerance_mm=tol, below_budget=None if tol is None else bool(tol < budget)))
    return tuple(out)


def execute_report(problem: PlanningProblem, result: PlanResult, runner: RolloutRunner | None,
                   options: ExecutionOptions, candidates: Sequence[PlanResult] = (), *,
                   finish: Callable[[PlanResult], PlanResult] | None = None,
                   on_progress: Callable[[str], None] | None = None) -> PlanResult:
    """``result`` (found) with its sequence success and its steps' execution (module doc);
    ``finish`` makes a chosen alternative a full plan (its steps simulated and annotated)."""
    if not result.found or not result.steps:
        return result
    runner = runner or InProcess()
    t0 = time.perf_counter()
    seed = int(problem.root_seed)
    plans = [result, *candidates]
    chosen, outcomes = 0, [[]]
    if candidates:
        chosen, outcomes = choose(problem, plans, runner, options, seed, on_progress)
    picked = plans[chosen]
    if chosen:  # the search's run, timings and bound are the chosen plan's too (its gap anew)
        t1 = time.perf_counter()
        picked = finish(picked) if finish is not None else picked
        bound = None if result.bound is None else dict(result.bound)
        if bound is not None and picked.robustness is not None:
            bound["gap"] = max(0.0, bound["robustness_upper"] - picked.robustness)
        picked = replace(picked, seconds=result.seconds, stats=result.stats, bound=bound,
                         eval_seconds=result.eval_seconds + time.perf_counter() - t1)
    rplan = rollout_plan(problem, picked, options)
    # the search's plan goes on from its rollouts; a chosen alternative is measured again on
    # fresh seeds (the best of several estimates is biased upward; module doc, 2)
    m_seed = int(np.random.SeedSequence(seed).generate_state(1)[0]) if chosen else seed
    m = measure(problem.assembly, rplan, runner, m_seed, half_width=options.half_width,
                max_rollouts=options.max_rollouts, prior=() if chosen else outcomes[0],
                on_progress=None if on_progress is None else
                (lambda d, t: on_progress(f"rollouts: {d} of up to {t}")))
    if on_progress is not None:
        on_progress("steps' clearance and tolerance")
    steps = _step_executions(problem, picked, m, options, seed, runner)
    report = SequenceReport(
        m.success.value, (m.success.low, m.success.high), m.success.successes, m.rollouts,
        {**options.errors.to_dict(), "carry": options.carry}, m_seed,
        "sequence success" if candidates else "product",
        tuple(_candidate(p, rplan_i, outs, i == chosen) for i, (p, rplan_i, outs) in enumerate(
            zip(plans, (rollout_plan(problem, p, options) for p in plans), outcomes))
            if candidates),
        time.perf_counter() - t0)
    return replace(picked, steps=tuple(replace(s, execution=e)
                                       for s, e in zip(picked.steps, steps)), sequence=report)
