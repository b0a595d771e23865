"""The search's refine loop, shared by its exact and beam modes: simulate where it decides.

``RefineLoop`` is a part of ``rap.plan.search.planner.SearchPlanner`` (a mixin: it reads the
planner's options ``simulations``, ``improve``, ``time_limit`` and ``bound_round``, and the run's
``gap``, ``SearchPlanner._gap``).
``_refine(run, choose, bound, incumbent_of)`` takes the search's run state
(``rap.plan.search.run.SearchRun``: its scores, its ``budget``) and a mode's three callbacks: the
choice by the current scores, the bound ``V`` on the optimum, and the best fully simulated
sequence so far (the incumbent ``I``). Each round it simulates the choice's operations neither
simulated nor trusted and chooses again, until the choice is settled, ``I`` reaches ``V`` (or
``(1 - gap) V``), or the budget (or ``time_limit``) is spent; then, with raised scores still in
the choice, it chooses once more by what is known. Phase 2: a choice settled short of the gap goes
on by the bounds themselves until within it, and never returns a worse plan than the settled
choice. The planner's module doc (3-4) says why. What it decides is kept on the run (``refined``,
the simulations it ran; ``stopped``; ``phase1``), and what it reports goes to the run's stats,
never read back (``stopped``, ``search_budget``, ``refine_simulations``, ``phase1_simulations``,
``phase2_simulations``, ``search_bound``, ``stopped_after``, ``predicted_robustness``).

Cost: the simulations it asks for, at most ``budget`` (``bound_round`` a round while choosing by
bounds, else the whole choice's), and a call of ``choose`` (and, when watching the bound,
``bound`` and ``incumbent_of``) a round. No ray, no torch.
"""

from __future__ import annotations

import math
import time

from rap.plan.dp import SLACK
from rap.plan.scoring.scorer import BudgetSpent
from rap.plan.search.run import SearchRun
from rap.plan.search.scores import SearchScores
from rap.plan.search.start import Start

__all__ = ["RefineLoop"]


class RefineLoop:
    """The refine loop and its rules (module doc); mixed into ``SearchPlanner``."""

    def _to_simulate(self, scores: SearchScores, ops) -> list:
        """The operations of a chosen sequence still worth a simulation: not simulated, and not
        trusted (predicted score below ``trust``); with bounds, the most raised first."""
        key, trust = scores.key, scores.trust
        todo = [op for op in ops if key(op) not in scores.simulated
                and (trust is None or scores.predicted[key(op)] < trust)]
        if scores.upper:
            todo.sort(key=lambda op: -scores.of(op) / max(scores.known(op), 1e-300))
        return todo

    def _batch(self, scores: SearchScores, todo: list, spent: int, budget: int) -> list:
        """This round's simulations: ``bound_round`` of ``todo`` while choosing by bounds, else all
        of it; never past the budget."""
        if scores.upper:
            todo = todo[:self.bound_round]
        return todo[:max(0, budget - spent)]

    def _spent(self, scores: SearchScores, spent: int, budget: int) -> bool:
        """Whether the refine loop must stop simulating: ``budget`` spent, or ``time_limit``
        seconds passed since the plan was asked for (checked between rounds; 0: no limit)."""
        return spent >= budget or bool(
            self.time_limit and time.perf_counter() - scores.scorer.started > self.time_limit)

    def _budget(self, start: Start | None) -> int:
        """The refine loop's simulations: ``simulations``; after greedy's start (complete), at most
        ``improve`` times the simulations greedy's plan took (the planner's module doc, 3)."""
        if start is None or not start.complete:
            return self.simulations  # no start, no plan, or one the time limit cut: the limit rules
        return min(self.simulations, math.ceil(self.improve * start.simulations))

    def _free_bound(self, scores: SearchScores) -> bool:
        """Whether the choosing scores are the upper bounds themselves (the DP's value is V)."""
        return scores.upper == 1.0 and not scores.optimism and scores.trust is None

    def _watching(self, run: SearchRun) -> bool:
        """Whether each round compares the incumbent with the bound: with the run's ``gap``, or
        when the bound comes free with the choice."""
        if not self.simulations:  # nothing simulated, no incumbent: the bound cannot stop it
            return False
        return run.gap is not None or self._free_bound(run.scores)

    def _settled(self, run: SearchRun, best: float, value: float, spent: int) -> bool:
        """Whether the incumbent ``best`` stops the search against the bound ``value``."""
        if best <= 0.0:
            return False
        if best >= value * SLACK:  # nothing left can beat it (the stronger claim first)
            run.stop("bound")
        elif run.gap is not None and best >= (1.0 - run.gap) * value:
            run.stop("gap", gap=run.gap)
        else:
            return False
        run.stats.update(search_bound=value, stopped_after=spent, predicted_robustness=best)
        return True

    def _second_phase(self, run: SearchRun, choice: dict, spent: int):
        """When the choice is settled short of the run's ``gap`` with budget left: phase 2 (the planner's
        module doc, 4) starts, choosing by the bounds themselves; returns what it must never fall
        below (the settled choice and its robustness by known scores), or None when it does not
        start."""
        scores = run.scores
        if not (run.gap is not None and not self._spent(scores, spent, run.budget)):
            return None
        scores.by_bounds()
        run.phase1 = spent
        run.stats.update(phase1_simulations=spent, gap=run.gap)
        return choice, math.prod(scores.known(op) for op in choice.values())

    @staticmethod
    def _kept(run: SearchRun, plan: dict | None, floor: tuple, spent: int) -> dict:
        """Phase 2's plan: ``plan`` (the incumbent, fully simulated) unless phase 1's settled
        choice (``floor``) is better by known scores (only when it has trusted operations)."""
        scores = run.scores
        r = 0.0 if plan is None else math.prod(scores.known(op) for op in plan.values())
        if r < floor[1]:
            plan, r = floor
        run.stats.update(phase2_simulations=spent - run.phase1, predicted_robustness=r)
        return plan

    def _refine(self, run: SearchRun, choose, bound, incumbent_of) -> dict:
        """Simulate where it decides until the choice settles, the bound stops it or the budget
        is spent (the planner's module doc, 3-4); returns the plan (subassembly -> operation).
        ``run.budget``: the simulations it may spend (``_budget``); ``run.refined``: those it ran.

        ``choose()``: ``(choice, value)``, the choice by the current scores and its DP value (or
        None); ``bound(value)``: ``V``; ``incumbent_of()``: ``(robustness, plan or None)`` of the
        best fully simulated sequence."""
        scores, stats, budget = run.scores, run.stats, run.budget
        spent = 0  # the loop's count: the budget itself once the scorer's own budget is spent
        run.refined = 0
        stats.update(search_budget=budget, refine_simulations=0)
        # phase 2 (the planner's module doc, 4): phase 1's settled choice and its robustness
        floor = None
        while True:
            choice, best = choose()
            if self._watching(run):
                value = bound(best)
                got, got_plan = incumbent_of()
                if self._settled(run, got, value, spent):
                    return got_plan if floor is None else self._kept(run, got_plan, floor, spent)
            todo = self._to_simulate(scores, choice.values())
            out = self._spent(scores, spent, budget)
            why = "budget" if spent >= budget else "time"
            if floor is not None and (not todo or out):
                run.stop(why, search_bound=value, stopped_after=spent)
                return self._kept(run, got_plan, floor, spent)
            if todo and out and scores.raised:
                # budget spent with raised scores still in the choice: choose by what is known
                scores.lower()
                continue
            if not todo and (floor := self._second_phase(run, choice, spent)):
                continue
            if not todo or out:
                stats["predicted_robustness"] = math.prod(scores.known(op)
                                                          for op in choice.values())
                run.stop(why if todo else "settled")
                return choice
            todo = self._batch(scores, todo, spent, budget)
            try:
                scores.simulate(todo)
            except BudgetSpent:  # the scorer's own budget (a service request's): stop here
                spent = budget
                continue
            spent += len(todo)
            run.refined = spent
            stats["refine_simulations"] = spent
