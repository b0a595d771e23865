"""The default planner: the best product of step scores over the AND/OR graph, with learned scores.

``SearchPlanner`` maximises R, the product of step scores, like ``OptimalPlanner``, but with the
CNN's expected score of an operation (``Scorer.expected_scores``) standing in for the simulator,
which is spent only where it decides. Its options and their measured defaults are
``rap.plan.search.options.SearchOptions``; docs/PLANNING.md explains each one.

1. **Greedy's plan first** (from ``greedy_from`` parts, and always beyond the exact budget):
   simulator-only greedy's plan, fully simulated, with every candidate greedy simulated known to
   the search; the result is never worse than it (stats: ``greedy_robustness``,
   ``greedy_seconds``, ``greedy_simulations``).
2. **Exact** (at most ``max_operations`` candidate operations, below ``beam_from`` parts): the
   optimum's DP over the reachable subassemblies by branch and bound
   (``rap.plan.dp.dp_choice_bounded``: a subassembly's candidates are scored only when they can
   still matter; with a scorer whose batches are cheaper, ``Scorer.batch_first``, the whole graph
   is scored in one batch first, the same scores and plans). An interlocked
   subassembly is a dead end (value 0), not a failure. **Beam** beyond it (e.g. 30 or 100 parts):
   ``rap.plan.search.beam``; greedy's plan joins the final beam, and after the refine (3) the
   chosen plan's runs of one-part steps are re-ordered ``window`` steps at a time with what is
   left of the budget (``rap.plan.search.windows``).
3. **Refine** (``_refine``, both modes): the chosen sequence's operations neither simulated nor
   trusted (predicted at ``trust`` or more) are simulated, their scores replace the predictions
   and the choice is made again, until it is settled or the budget is spent: ``simulations``, or
   after greedy's start ``improve`` times greedy's own simulations (at most ``simulations``). While
   choosing, an unsimulated operation counts as ``max(p + optimism (1 - p), p + upper (u - p))``,
   ``u`` its conformal upper bound (``rap.model.calibration``; ``rap.plan.search.scores``), so
   an alternative the model may underrate is chosen, simulated and kept if it holds up; with
   ``upper`` > 0, ``bound_round`` operations a round, the most raised first. When the budget (or
   ``time_limit``) stops it, the plan is chosen again by what is known; in exact mode its
   remaining steps are simulated and the best fully simulated sequence is returned (it may
   combine subtrees of several simulated plans, greedy's among them; stats ``final``).
4. **Bound**: ``V``, the best product of upper bounds (simulated scores where known) over every
   sequence, bounds the optimum's robustness at ``confidence`` (Bonferroni over the steps). The
   best fully simulated sequence is the incumbent ``I``; the search stops when ``I >= V``
   (``bound``) or, with ``gap``, ``I >= (1 - gap) V``. Phase 2: when the choice is settled short
   of the gap, it goes on by the bounds themselves until within it, and returns the incumbent,
   never a worse plan than the settled choice (``stats``: ``stopped``, ``phase1_simulations``,
   ``phase2_simulations``, ``search_bound``). In beam mode ``V`` and ``I`` range over the final
   beam's sequences only (the bound's ``scope``: ``beam``).
5. **A bound with every plan**: after the plan's steps are simulated for its evaluation, ``V`` is
   computed again with those scores (never below R) and reported as ``PlanResult.bound``
   (``rap.plan.search.scores.report``); its time is ``stats["bound_seconds"]``.

With a perfect model the exact mode returns the optimum; with zero-width bounds too, ``V`` is the
optimum. Each step says where its score came from: ``sim`` or ``cnn``. Variants measured not to
pay (per-assembly score correction, sequential tests, scoring the whole graph first whatever the
scorer) live in ``research/variants/``.

Cost: one scorer batch per subassembly visited (exact; 65-71% of the graph's operations on
held-out assemblies with the CNN), or the whole graph in one batch where the scorer says that is
cheaper (``Scorer.batch_first``: the default scorer), or one batch per round (beam); the
simulations asked for; and the bound's DP (``max_value``). No ray, no torch.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

from rap.model.calibration import ScoreBounds, load
from rap.plan.dp import SLACK, dp_choice_bounded, max_value
from rap.plan.search.beam import beam_states, log_product
from rap.plan.search.options import SearchOptions
from rap.plan.search.scores import SearchScores, incumbent, report
from rap.plan.search.start import Start, greedy_start
from rap.plan.search.windows import polish
from rap.plan.graph import Interlocked, TooLarge, assembly_order, dead_end, reachable
from rap.plan.planners.base import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStep
from rap.stats import bonferroni
from rap.plan.scoring.scorer import Budget, BudgetSpent, Scorer

__all__ = ["SearchPlanner"]

_CURRENT = threading.local()  # .run: the _Run of the search solving in this thread


@dataclass
class _Run:
    """What one search leaves for its plan's bound: the scores, and the graph (exact) or the
    final beam's sequences."""

    scores: SearchScores
    graph: dict | None = None
    beam: list | None = None


class SearchPlanner(Planner):
    """See the module doc. ``SearchOptions`` declares the options, their ranges and the shipped
    defaults: ``SearchPlanner()`` is the shipped search. ``bounds``: the score bounds (None: the
    scorer's own, ``Scorer.bounds``, else ``rap.model.calibration.load()``, the CNN's)."""

    name = "search"
    options_class = SearchOptions

    def __init__(self, options: SearchOptions | None = None, *, bounds: ScoreBounds | None = None,
                 **changes):
        if "gap" in changes and changes["gap"] is None:
            changes["gap"] = 0.0  # None or 0: off
        super().__init__(options, **changes)
        self.gap = self.gap or None
        self.bounds = bounds

    def solve(self, problem: PlanningProblem, scorer: Scorer) -> PlanResult:
        """``Planner.solve``, then the plan's bound (module doc, 5), outside the scorer's budget (a
        request's), as the evaluation is."""
        _CURRENT.run = None
        result = super().solve(problem, scorer)
        run, _CURRENT.run = _CURRENT.run, None
        if not result.found or run is None:
            return result
        t = time.perf_counter()
        before = scorer.stats.to_dict()
        saved, scorer.budget = scorer.budget, Budget()  # like the evaluation: not the search's
        try:
            bound = self._bound(run, result)
        finally:
            scorer.budget = saved
        stats = dict(result.stats)
        for k, v in scorer.stats.to_dict().items():  # the bound's CNN batches count too
            stats[k] = stats.get(k, 0) + v - before[k]
        stats["bound_seconds"] = time.perf_counter() - t
        return result.with_(bound=bound, stats=stats)

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
        ``improve`` times the simulations greedy's plan took (module doc, 3)."""
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
        """When the choice is settled short of ``gap`` with budget left: phase 2 (module doc, 5)
        starts, choosing by the bounds themselves; returns what it must never fall below (the
        settled choice and its robustness by known scores), or None when it does not start."""
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

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        # the bounds fitted for the scorer's own numbers (the default scorer carries its own),
        # else the shipped calibration of the CNN; chosen per solve, never kept
        bounds = self.bounds if self.bounds is not None else (scorer.bounds or load())
        raise_ = self.simulations > 0  # raised scores choose what to simulate: none to choose
        scores = SearchScores(problem, scorer, bounds,
                              bonferroni(self.confidence, len(whole) - 1),
                              self.optimism if raise_ else 0.0, self.upper if raise_ else 0.0,
                              self.trust)
        graph = None
        if len(whole) < self.beam_from:  # else the walk, 1-4 s, would only find it too large
            try:
                graph = reachable(problem, self.max_operations)
            except TooLarge:
                pass
        run = _Run(scores, graph)
        # greedy's plan first (module doc, 1-2): from ``greedy_from`` parts, and always for the beam
        start = (greedy_start(problem, scorer, scores, stats, self.time_limit)
                 if graph is None or len(whole) >= self.greedy_from else None)
        budget = self._budget(start)
        if graph is not None:
            stats["search"] = "exact"
            trees = self._exact(graph, scores, whole, stats, budget)
        else:
            stats["search"] = "beam"
            trees = self._beam(problem, scores, stats, run, budget, start.sequence)
        _CURRENT.run = run
        steps = {}
        for sub, op in trees.items():
            k = scores.key(op)
            steps[sub] = PlanStep.of(op, "sim" if k in scores.simulated else "cnn",
                                     score=scores.simulated.get(k),
                                     confidence=scores.predicted.get(k))
        # the refine loop's simulations (greedy's own are ``greedy_simulations``)
        stats["search_simulations"] = len(scores.simulated) - stats.get("greedy_known", 0)
        stats["predicted_operations"] = len(scores.predicted)
        return assembly_order(steps, whole)

    def _bound(self, run: _Run, result: PlanResult) -> dict:
        """The plan's ``bound`` block with its own simulated scores counted (module doc, 6)."""
        scores = run.scores
        scores.add_simulated([s.to_operation() for s in result.steps],
                             [s.score for s in result.steps])
        if run.graph is not None:
            value, scope = self._max_high(run.graph, scores, scores.problem.whole), "exact"
        else:
            value = self._beam_value(run, scores)
            scope = "beam"
        return report(result.robustness, value, self.confidence, scope, scores.bounds,
                      len(result.steps), scores.level)

    @staticmethod
    def _beam_value(run: _Run, scores: SearchScores) -> float:
        """``V`` over the final beam's sequences only (the bound's scope ``beam``)."""
        return max(math.prod(scores.high(op) for op in seq) for seq in run.beam)

    @staticmethod
    def _max_high(graph, scores: SearchScores, whole) -> float:
        """``V``: the best product of upper bounds (simulated scores where known)."""
        def scores_of(s):
            if scores.bounds.calibrated:  # uncalibrated: every bound is 1, no CNN needed
                scores.predict(graph[s])
            return scores.scores("high", s, graph[s])

        return max_value(graph, scores_of, whole, scores.memo("high"))

    # -- the refine loop, shared by both modes --------------------------------------------------
    def _refine(self, scores: SearchScores, stats: dict, budget: int, choose, bound,
                incumbent_of) -> dict:
        """Simulate where it decides until the choice settles, the bound stops it or the budget
        is spent (module doc, 3-5); returns the plan (subassembly -> operation).
        ``budget``: the simulations it may spend (``_budget``).

        ``choose()``: ``(choice, value)``, the choice by the current scores and its DP value (or
        None); ``bound(value)``: ``V``; ``incumbent_of()``: ``(robustness, plan or None)`` of the
        best fully simulated sequence."""
        spent = 0
        stats.update(search_budget=budget, refine_simulations=0)
        floor = None  # phase 2 (module doc, 5): phase 1's settled choice and its robustness
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

    # -- exact ------------------------------------------------------------------------------------
    def _exact(self, graph, scores: SearchScores, whole, stats, budget: int) -> dict:
        stats.update(subassemblies=len(graph), operations=sum(len(c) for c in graph.values()))
        if scores.scorer.batch_first:  # the default scorer: the whole graph at once is cheaper
            scores.predict([op for c in graph.values() for op in c])

        def scores_of(s):  # predicted on the first visit, one CNN batch per subassembly
            if not scores.cached("of", s):
                scores.predict(graph[s])
            return scores.scores("of", s, graph[s])

        def choose():
            best, tree = dp_choice_bounded(graph, scores_of, whole, scores.memo("of"))
            if best <= 0.0:
                raise Interlocked(dead_end(graph, whole))
            return {sub: op for sub, (_, op) in tree.items()}, best

        plan = self._refine(
            scores, stats, budget, choose,
            lambda best: best if self._free_bound(scores) else self._max_high(graph, scores, whole),
            lambda: incumbent(graph, scores, whole))
        if stats.get("stopped") not in ("budget", "time") or not stats["search_budget"]:
            return plan  # settled; or the model alone (no simulation while planning)
        return self._best_simulated(graph, scores, whole, plan, stats)

    @staticmethod
    def _best_simulated(graph, scores: SearchScores, whole, plan: dict, stats: dict) -> dict:
        """When the budget stopped the search (module doc, 3): the chosen plan's steps not yet
        simulated are simulated (its evaluation would simulate them anyway), and the best fully
        simulated sequence is returned: the plan, or a better one combining the subtrees
        simulated so far (greedy's plan among them). A plan with trusted or unsimulated steps
        (the scorer's own budget spent) is kept unless a simulated sequence beats it."""
        before = len(scores.simulated)
        try:
            scores.simulate(plan.values())
        except BudgetSpent:
            pass
        stats["final_simulations"] = len(scores.simulated) - before
        got, got_plan = incumbent(graph, scores, whole)
        mine = math.prod(scores.known(op) for op in plan.values())
        if got_plan is None or got <= mine:
            return plan
        stats.update(final="incumbent", predicted_robustness=got)
        return got_plan

    # -- beam -------------------------------------------------------------------------------------
    def _beam(self, problem: PlanningProblem, scores: SearchScores, stats, run: _Run,
              budget: int, first: tuple = ()) -> dict:
        beam, rounds = beam_states(problem, scores, self.beam_width)
        stats.update(beam_rounds=rounds, beam_width=self.beam_width)
        if first and all(st[3] != first for st in beam):  # greedy's plan competes (module doc, 2)
            beam.append((log_product(scores, first), max(st[1] for st in beam) + 1, (), first))
        run.beam = [[op for _, op in st[3]] for st in beam]
        # simulations where they matter: re-rank the final sequences by mixed products
        ranked: list = []

        def choose():
            ranked[:] = sorted(beam, key=lambda st: (-log_product(scores, st[3]), st[1]))
            return dict(ranked[0][3]), None

        def incumbent_of():
            full = [st[3] for st in ranked if all(scores.is_simulated(op) for _, op in st[3])]
            if not full:
                return 0.0, None
            got = max((math.prod(scores.known(op) for _, op in seq), -i)
                      for i, seq in enumerate(full))
            return got[0], dict(full[-got[1]])

        plan = self._refine(scores, stats, budget, choose,
                            lambda _: self._beam_value(run, scores),
                            incumbent_of)
        left = budget - stats["refine_simulations"]
        if self.window and left > 0 and len(plan) == len(problem.whole) - 1:
            deadline = (scores.scorer.started + self.time_limit) if self.time_limit else None
            plan = polish(problem, scores, plan, self.window, left, stats, deadline)
            run.beam.append(list(plan.values()))  # the bound's scope covers the polished plan
        return plan


SearchOptions.planner = SearchPlanner
