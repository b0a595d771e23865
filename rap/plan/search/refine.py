"""The search's refine loop, shared by its exact and beam modes: simulate where it decides.

``RefineLoop`` is a part of ``rap.plan.search.planner.SearchPlanner`` (a mixin: it reads the
planner's options ``simulations``, ``improve``, ``time_limit``, ``gap`` and ``bound_round``).
``_refine(scores, stats, budget, choose, bound, incumbent_of)`` takes a mode's three callbacks: the
choice by the current scores, the bound ``V`` on the optimum, and the best fully simulated
sequence so far (the incumbent ``I``). Each round it simulates the choice's operations neither
simulated nor trusted and chooses again, until the choice is settled, ``I`` reaches ``V`` (or
``(1 - gap) V``), or the budget (or ``time_limit``) is spent; then, with raised scores still in
the choice, it chooses once more by what is known. Phase 2: a choice settled short of the gap goes
on by the bounds themselves until within it, and never returns a worse plan than the settled
choice. The planner's module doc (3-4) says why; the stats it writes are named there
(``stopped``, ``search_budget``, ``refine_simulations``, ``phase1_simulations``,
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

    def _watching(self, scores: SearchScores) -> bool:
        """Whether each round compares the incumbent with the bound: with ``gap``, or when the
        bound comes free with the choice."""
        if not self.simulations:  # nothing simulated, no incumbent: the bound cannot stop it
            return False
        return self.gap is not None or self._free_bound(scores)

    def _settled(self, best: float, value: float, spent: int, stats: dict) -> bool:
        """Whether the incumbent ``best`` stops the search against the bound ``value``."""
        if best <= 0.0:
            return False
        if best >= value * SLACK:  # nothing left can beat it (the stronger claim first)
            stats["stopped"] = "bound"
        elif self.gap is not None and best >= (1.0 - self.gap) * value:
            stats.update(stopped="gap", gap=self.gap)
        else:
            return False
        stats.update(search_bound=value, stopped_after=spent, predicted_robustness=best)
        return True

    def _second_phase(self, scores: SearchScores, choice: dict, spent: int, budget: int,
                      stats: dict):
        """When the choice is settled short of ``gap`` with budget left: phase 2 (the planner's
        module doc, 4) starts, choosing by the bounds themselves; returns what it must never fall
        below (the settled choice and its robustness by known scores), or None when it does not
        start."""
        if not (self.gap is not None and not self._spent(scores, spent, budget)):
            return None
        scores.by_bounds()
        stats.update(phase1_simulations=spent, gap=self.gap)
        return choice, math.prod(scores.known(op) for op in choice.values())

    @staticmethod
    def _kept(scores: SearchScores, plan: dict | None, floor: tuple, spent: int,
              stats: dict) -> dict:
        """Phase 2's plan: ``plan`` (the incumbent, fully simulated) unless phase 1's settled
        choice (``floor``) is better by known scores (only when it has trusted operations)."""
        r = 0.0 if plan is None else math.prod(scores.known(op) for op in plan.values())
        if r < floor[1]:
            plan, r = floor
        stats.update(phase2_simulations=spent - stats["phase1_simulations"],
                     predicted_robustness=r)
        return plan

    def _refine(self, scores: SearchScores, stats: dict, budget: int, choose, bound,
                incumbent_of) -> dict:
        """Simulate where it decides until the choice settles, the bound stops it or the budget
        is spent (the planner's module doc, 3-4); returns the plan (subassembly -> operation).
        ``budget``: the simulations it may spend (``_budget``).

        ``choose()``: ``(choice, value)``, the choice by the current scores and its DP value (or
        None); ``bound(value)``: ``V``; ``incumbent_of()``: ``(robustness, plan or None)`` of the
        best fully simulated sequence."""
        spent = 0
        stats.update(search_budget=budget, refine_simulations=0)
        # phase 2 (the planner's module doc, 4): phase 1's settled choice and its robustness
        floor = None
        while True:
            choice, best = choose()
            if self._watching(scores):
                value = bound(best)
                got, got_plan = incumbent_of()
                if self._settled(got, value, spent, stats):
                    return got_plan if floor is None else self._kept(scores, got_plan, floor,
                                                                     spent, stats)
            todo = self._to_simulate(scores, choice.values())
            out = self._spent(scores, spent, budget)
            why = "budget" if spent >= budget else "time"
            if floor is not None and (not todo or out):
                stats.update(stopped=why, search_bound=value, stopped_after=spent)
                return self._kept(scores, got_plan, floor, spent, stats)
            if todo and out and scores.raised:
                # budget spent with raised scores still in the choice: choose by what is known
                scores.lower()
                continue
            if not todo and (floor := self._second_phase(scores, choice, spent, budget, stats)):
                continue
            if not todo or out:
                stats["predicted_robustness"] = math.prod(scores.known(op)
                                                          for op in choice.values())
                stats["stopped"] = why if todo else "settled"
                return choice
            todo = self._batch(scores, todo, spent, budget)
            try:
                scores.simulate(todo)
            except BudgetSpent:  # the scorer's own budget (a service request's): stop here
                spent = budget
                continue
            spent += len(todo)
            stats["refine_simulations"] = spent
