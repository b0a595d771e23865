"""The planner contract: ``Planner.solve(problem, scorer) -> PlanResult``, and its options.

Every planner takes a ``PlanningProblem`` and a scorer (``rap.plan.scoring.scorer.ScorerProtocol``,
implemented by ``Scorer``) and returns a ``PlanResult`` with a status (OMPL's
``Planner::solve(ProblemDefinition) -> PlannerStatus``). Plans are found by
assembly-by-disassembly: a subassembly ``S`` is split by one of ``problem.candidates(S)`` into a
moving and a fixed subassembly, and both sides are planned the same way down to single parts. The
returned steps are in assembly order (children before parents: the disassembly sequence reversed),
and every returned sequence is evaluated by the simulator (``PlanResult.robustness`` = the product
of the step scores), then annotated with robot poses, intervals and reasons
(``rap.plan.report.poses``).

A planner's options are one frozen dataclass (``options_class``, a
``rap.plan.planners.options.PlannerOptions``): ``Planner()`` is the shipped method, ``Planner(
options)`` a chosen one, ``Planner(name=value, ...)`` the shipped one with those options changed
(checked by the options class: ``ParameterError`` names a bad value). The families: greedy
(``rap.plan.planners.greedy``: RAP, simulator-only), the optimum (``optimal``), random sequences
(``random_sequences``) and the search (``rap.plan.search``). No ray, no torch.
"""

from __future__ import annotations

import abc
import dataclasses
import math
import time
from typing import ClassVar, Sequence

from rap.plan.cell.rules import blocked_by, constraint_stats
from rap.plan.scoring.familiarity import guard_stats
from rap.plan.graph import Interlocked
from rap.plan.planners.options import PlannerOptions
from rap.plan.problem import PlanningProblem
from rap.plan.report.poses import annotate_plan
from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
from rap.plan.scoring.scorer import Budget, BudgetSpent, ScorerProtocol

__all__ = ["Planner", "evaluate_steps", "HIGH_PROBABILITY"]

HIGH_PROBABILITY = 0.5  # the CNN's class decision: P(high) >= 0.5 is "high"


def evaluate_steps(problem: PlanningProblem, scorer: ScorerProtocol,
                   steps: Sequence[PlanStep]) -> list[PlanStep]:
    """The steps with their simulator scores (one batch; cached scores reused)."""
    scores = scorer.scores(problem, [s.to_operation() for s in steps])
    return [dataclasses.replace(s, score=sc) for s, sc in zip(steps, scores)]


class Planner(abc.ABC):
    """Base class: ``solve(problem, scorer) -> PlanResult``; subclasses implement ``_search`` and
    name their ``options_class`` (module doc). Each declared option is an attribute."""

    name: str = ""
    options_class: ClassVar[type[PlannerOptions]] = PlannerOptions

    def __init__(self, options: PlannerOptions | None = None, **changes):
        options = self.options_class() if options is None else options
        if not isinstance(options, self.options_class):
            raise TypeError(f"{type(self).__name__} takes {self.options_class.__name__}, not "
                            f"{type(options).__name__}")
        self.options = dataclasses.replace(options, **changes) if changes else options
        for o in self.options.declared():
            setattr(self, o.name, getattr(self.options, o.name))

    def solve(self, problem: PlanningProblem, scorer: ScorerProtocol) -> PlanResult:
        return self._solve(problem, scorer, self._search, {})

    def _solve(self, problem: PlanningProblem, scorer: ScorerProtocol, search,
               stats: dict) -> PlanResult:
        """``solve`` with ``search(problem, scorer, stats)`` in ``_search``'s place, its counters
        in ``stats``: a planner that passes a run state of its own to its search
        (``rap.plan.search.run.SearchRun``) passes that run's search and stats."""
        t0 = time.perf_counter()
        scorer.started = t0
        base = scorer.stats.to_dict()

        def counters() -> dict:
            now = scorer.stats.to_dict()
            return {k: now[k] - base[k] for k in now}

        stats.update(constraint_stats(problem))  # the cell's constraints, the scores' scope
        try:  # a single part needs no step
            steps = search(problem, scorer, stats) if len(problem.whole) >= 2 else []
            stats.update(guard_stats(scorer, problem))  # the default scorer's guard, if it acted
        except Interlocked as exc:
            culprit, message = blocked_by(problem, exc.subset)  # an interlock or a constraint
            return PlanResult(PlanStatus.INFEASIBLE, self.name, problem.assembly.name,
                              seconds=time.perf_counter() - t0,
                              interlocked=tuple(sorted(culprit)),
                              stats={**stats, **counters(),
                                     "stuck_at": sorted(exc.subset), "blocked": message},
                              message=message)
        except BudgetSpent as exc:
            return PlanResult(PlanStatus.BUDGET_SPENT, self.name, problem.assembly.name,
                              seconds=time.perf_counter() - t0,
                              stats={**stats, **counters()}, message=str(exc))
        seconds = time.perf_counter() - t0
        t1 = time.perf_counter()
        before = scorer.stats.sim_run
        saved, scorer.budget = scorer.budget, Budget()  # evaluation is not part of the search
        try:
            steps = evaluate_steps(problem, scorer, steps)
        finally:
            scorer.budget = saved
        eval_seconds = time.perf_counter() - t1
        stats["eval_simulations"] = scorer.stats.sim_run - before
        robustness = float(math.prod(s.score for s in steps))  # type: ignore[misc]
        # what a controller and a user read: poses, intervals, reasons (rap.plan.report.poses)
        return annotate_plan(PlanResult(PlanStatus.FOUND, self.name, problem.assembly.name,
                                        tuple(steps), robustness, seconds, eval_seconds,
                                        stats={**stats, **counters()}), problem)

    @abc.abstractmethod
    def _search(self, problem: PlanningProblem, scorer: ScorerProtocol,
                stats: dict) -> list[PlanStep]:
        """The steps in assembly order (scores filled in later), or raise ``Interlocked``; the
        problem has at least two parts."""
