"""The search's first complete plan: simulator-only greedy's, with everything greedy simulated.

``greedy_start(problem, scorer, scores, stats, time_limit)`` returns a ``Start``. It runs
``SimPlanner`` (every candidate of each subassembly on its way simulated, the best taken) and
makes every score it simulated known to the search (``SearchScores.add_simulated``: those
candidates are exact from then on). The search then only improves on that plan: it never returns
a worse one (``rap.plan.search.planner``, module doc, 1). With a ``time_limit``, greedy may take at most ``GREEDY_SHARE`` of it: past
that, the levels left are chosen by the model's expected scores, without simulation (an anytime
greedy, ``rap.plan.planners.greedy``'s ``finish``), so a first plan exists whatever the limit. At
the caller's own budget, or at a dead end, there is no first plan (an empty ``sequence``) and the
search goes on without one.

Stats: ``greedy_simulations``, ``greedy_steps``, ``greedy_seconds``, ``greedy_robustness`` (None
when a step was chosen by the model or there is no plan), ``greedy_by_model`` (the steps the model
chose), ``greedy_known`` (simulated scores known after it; free operations' are not). Cost:
greedy's simulations (its candidates' scores are read back from the score cache). No ray, no torch.
"""

from __future__ import annotations

import dataclasses
import math
import time

from rap.plan.graph import Interlocked
from rap.plan.dp import argmax_first
from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStep
from rap.plan.scoring.scorer import BudgetSpent, ScorerProtocol
from rap.plan.search.options import GREEDY_SHARE

__all__ = ["Start", "greedy_start"]


@dataclasses.dataclass(frozen=True)
class Start:
    """Greedy's first plan for the search: ``sequence``, its ``(subassembly, operation)`` pairs
    (``()``: none); ``simulations``, what greedy simulated; ``complete``, whether every step was
    chosen by simulation (not cut by the time limit), so that its simulations can set the
    search's budget (``rap.plan.search.planner``, module doc, 3); ``known``, the simulated scores
    the search knows after it (free operations' are not), so that the search counts only its own
    simulations."""

    sequence: tuple = ()
    simulations: int = 0
    complete: bool = False
    known: int = 0


def greedy_start(problem: PlanningProblem, scorer: ScorerProtocol, scores, stats: dict,
                 time_limit: float = 0.0) -> Start:
    """Greedy's first plan (module doc); its figures also go to ``stats``."""
    t = time.perf_counter()
    before = scorer.stats.sim_run
    saved = scorer.budget
    greedy, finished = SimPlanner(), set()
    if time_limit:
        cap = GREEDY_SHARE * time_limit
        scorer.budget = dataclasses.replace(saved, max_seconds=min(
            cap, saved.max_seconds if saved.max_seconds is not None else cap))

        def finish(problem, scorer, cands, stats):  # the model's best candidate, no simulation
            scorer.budget = saved
            flat = [op for c in cands for op in c]
            expected, out, i = scorer.expected_scores(problem, flat), [], 0
            for c in cands:
                j = argmax_first(expected[i:i + len(c)])
                out.append(PlanStep.of(c[j], "model", predicted=float(expected[i + j])))
                finished.add(c[j].moving | c[j].fixed)
                i += len(c)
            return out

        greedy.finish = finish
    inner: dict = {}
    try:
        steps = greedy._search(problem, scorer, inner)
        ops = [s.to_operation() for s in steps]
        known = [c for op in ops if op.moving | op.fixed not in finished
                 for c in problem.candidates(op.moving | op.fixed)]
        known_scores = scorer.scores(problem, known)  # score cache hits
    except (BudgetSpent, Interlocked):  # a budget, or a dead end: the search decides
        simulations = scorer.stats.sim_run - before
        stats.update(greedy_simulations=simulations, greedy_robustness=None)
        return Start(simulations=simulations)
    finally:
        scorer.budget = saved
    simulations = scorer.stats.sim_run - before
    stats.update(greedy_simulations=simulations, greedy_steps=len(ops),
                 greedy_seconds=time.perf_counter() - t,
                 greedy_robustness=(None if finished else math.prod(s.score for s in steps)))
    if finished:
        stats["greedy_by_model"] = len(finished)
    scores.add_simulated(known, known_scores)
    # the model's steps are predicted for the search (one batch; simulated ones need none)
    scores.predict([op for op in ops if not scores.is_simulated(op)])
    stats["greedy_known"] = scores.simulations
    return Start(tuple((op.moving | op.fixed, op) for op in ops), simulations,
                 complete=not finished, known=scores.simulations)
