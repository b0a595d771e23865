"""The default planner: the best product of step scores over the AND/OR graph, with learned scores.

``SearchPlanner`` maximises R, the product of step scores, like ``OptimalPlanner``, but with the
CNN's expected score of an operation (``Scorer.expected_scores``) standing in for the simulator,
which is spent only where it decides. Its options and their measured defaults are
``rap.plan.search.options.SearchOptions``; docs/PLANNING.md explains each one.

1. **Greedy's plan first** (from ``greedy_from`` parts, and always beyond the exact budget):
   simulator-only greedy's plan, fully simulated, with every candidate greedy simulated known to
   the search; the result is never worse than it (stats: ``greedy_robustness``,
   ``greedy_seconds``, ``greedy_simulations``).
2. **Exact** (at most ``max_operations`` candidate operations, below ``beam_from`` parts;
   ``rap.plan.search.exact``): the optimum's DP over the reachable subassemblies by branch and
   bound (``rap.plan.dp.dp_choice_bounded``: a subassembly's candidates are scored only when they
   can still matter; with a scorer whose batches are cheaper, ``Scorer.batch_first``, the whole
   graph is scored in one batch first, the same scores and plans). An interlocked
   subassembly is a dead end (value 0), not a failure. **Beam** beyond it (e.g. 30 or 100 parts):
   ``rap.plan.search.beam``; greedy's plan joins the final beam, and after the refine (3) the
   chosen plan's runs of one-part steps are re-ordered ``window`` steps at a time with what is
   left of the budget (``rap.plan.search.windows``).
3. **Refine** (``rap.plan.search.refine``, both modes): the chosen sequence's operations neither
   simulated nor trusted (predicted at ``trust`` or more) are simulated, their scores replace the
   predictions and the choice is made again, until it is settled or the budget is spent:
   ``simulations``, or after greedy's start ``improve`` times greedy's own simulations (at most
   ``simulations``). While
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
   ``phase2_simulations``, ``search_bound``). The run's gap is ``_gap(run)``: the option; a
   variant may choose it per assembly (``research/variants/guard_gap.py``: a gap kept on an
   assembly the scorer's guard found unfamiliar, measured not to pay). In beam mode ``V`` and
   ``I`` range over the final beam's sequences only (the bound's ``scope``: ``beam``).
5. **A bound with every plan**: after the plan's steps are simulated for its evaluation, ``V`` is
   computed again with those scores (never below R) and reported as ``PlanResult.bound``
   (``rap.plan.search.scores.report``); its time is ``stats["bound_seconds"]``.

With a perfect model the exact mode returns the optimum; with zero-width bounds too, ``V`` is the
optimum. Each step says where its score came from: ``sim`` or ``cnn``. Variants measured not to
pay (per-assembly score correction, sequential tests, scoring the whole graph first whatever the
scorer) live in ``research/variants/``.

6. **Alternatives** (option ``alternatives`` = K, default 0: none): ``search`` returns, beside the
   plan, up to K other distinct complete plans the search knows, best first by their products of
   known scores (exact: the K best trees of the graph; beam: the final beam's sequences), with no
   simulation (``rap.plan.search.alternatives``). The plan is the same whatever K.

``SearchPlanner`` is put together from its parts, one idea a module: this module holds the run
(``search``: the search, then the plan's bound and the alternatives) and the choice of mode;
``ExactMode`` (``rap.plan.search.exact``), ``BeamMode`` (``rap.plan.search.beam``) and
``RefineLoop`` (``rap.plan.search.refine``) are mixed in, and a variant overrides their methods
as it would the planner's (``research/variants/eager.py``). Each call's state is a
``rap.plan.search.run.SearchRun``, passed to them as an argument (never kept on the planner,
which concurrent requests may share): decisions read its typed fields, and ``stats`` is output.

Cost: one scorer batch per subassembly visited (exact; 65-71% of the graph's operations on
held-out assemblies with the CNN), or the whole graph in one batch where the scorer says that is
cheaper (``Scorer.batch_first``: the default scorer), or one batch per round (beam); the
simulations asked for; and the bound's DP (``max_value``); with K alternatives, the K-best DP
(no simulation; stats ``alternatives``, ``alternatives_seconds``). No ray, no torch.

Example::

    from rap.plan.search.planner import SearchPlanner

    outcome = SearchPlanner(alternatives=4).search(problem, scorer)
    outcome.plan                    # the PlanResult that solve() returns
    for alt, r in zip(outcome.alternatives, outcome.estimates):
        print(len(alt.steps), r)    # other complete plans, best first, with no simulation
"""

from __future__ import annotations

import time
from typing import Callable

from rap.model.calibration import ScoreBounds, load
from rap.plan.search.alternatives import SearchOutcome, alternatives
from rap.plan.search.beam import BeamMode
from rap.plan.search.exact import ExactMode
from rap.plan.search.options import SearchOptions
from rap.plan.search.refine import RefineLoop
from rap.plan.search.run import SearchRun
from rap.plan.search.scores import SearchScores, report
from rap.plan.search.start import greedy_start
from rap.plan.graph import TooLarge, assembly_order, reachable
from rap.plan.planners.base import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStep
from rap.stats import bonferroni
from rap.plan.scoring.scorer import Budget, ScorerProtocol

__all__ = ["SearchPlanner", "SearchOutcome"]


class SearchPlanner(ExactMode, BeamMode, RefineLoop, Planner):
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

    def solve(self, problem: PlanningProblem, scorer: ScorerProtocol) -> PlanResult:
        """``Planner.solve``, then the plan's bound (module doc, 5): ``search(...).plan``."""
        return self.search(problem, scorer).plan

    def search(self, problem: PlanningProblem, scorer: ScorerProtocol) -> SearchOutcome:
        """The search's plan and, with the option ``alternatives`` = K, up to K other distinct
        complete plans it knows (module doc, 6; ``rap.plan.search.alternatives``).

        Parameters: ``problem``, ``scorer`` as for ``solve``. Returns a ``SearchOutcome``:
        ``plan``, what ``solve`` returns (evaluated, annotated, with its bound), the same for
        every K; ``alternatives``, found plans (steps in assembly order; a step's score the
        simulator's where the search knows it, else None and its ``predicted`` the model's
        expected score), not annotated, best first by ``estimates``, their
        products of scores as the search knows them (simulated where known, else the model's
        expected score); empty when K is 0 or the plan is not found. Raises what ``solve``
        raises. The plan's bound and the alternatives are computed outside the scorer's budget,
        as the evaluation is."""
        run = SearchRun(problem, scorer)
        result = self._solve(problem, scorer, lambda *_: self._plan(run), run.stats)
        if not result.found or run.scores is None:
            return SearchOutcome(result)
        bound, stats = self._after(scorer, result, "bound_seconds",
                                   lambda: self._bound(run, result))
        result = result.with_(bound=bound, stats=stats)
        if not self.alternatives:
            return SearchOutcome(result)
        outcome, stats = self._after(scorer, result, "alternatives_seconds",
                                     lambda: alternatives(run, result, self.alternatives))
        stats["alternatives"] = len(outcome.alternatives)
        return SearchOutcome(result.with_(stats=stats), outcome.alternatives, outcome.estimates)

    @staticmethod
    def _after(scorer: ScorerProtocol, result: PlanResult, seconds: str, work: Callable):
        """``(work(), stats)``: ``work`` run after the search, outside the scorer's budget (a
        request's) as the evaluation is; ``stats``, the result's with the scorer's counters
        during ``work`` added (its CNN batches count too) and its time as ``seconds``."""
        t = time.perf_counter()
        before = scorer.stats.to_dict()
        saved, scorer.budget = scorer.budget, Budget()  # like the evaluation: not the search's
        try:
            out = work()
        finally:
            scorer.budget = saved
        stats = dict(result.stats)
        for k, v in scorer.stats.to_dict().items():
            stats[k] = stats.get(k, 0) + v - before[k]
        stats[seconds] = time.perf_counter() - t
        return out, stats

    def _search(self, problem, scorer, stats):
        """``Planner._search``: the steps, with a run state of the call's own."""
        return self._plan(SearchRun(problem, scorer, stats))

    def _plan(self, run: SearchRun) -> list[PlanStep]:
        """The search (module doc, 1-4) on ``run``: its steps in assembly order."""
        problem, scorer, stats = run.problem, run.scorer, run.stats
        whole = problem.whole
        # the bounds fitted for the scorer's own numbers (the default scorer carries its own),
        # else the shipped calibration of the CNN; chosen per solve, never kept
        bounds = self.bounds if self.bounds is not None else (scorer.bounds or load())
        raise_ = self.simulations > 0  # raised scores choose what to simulate: none to choose
        run.scores = scores = SearchScores(problem, scorer, bounds,
                                           bonferroni(self.confidence, len(whole) - 1),
                                           self.optimism if raise_ else 0.0,
                                           self.upper if raise_ else 0.0, self.trust)
        # the guard's verdict first (judged once per assembly, the first thing the scorer does with
        # it anyway): the scorer's ``batch_first`` follows the assembly judged last
        scorer.guard_report(problem)
        run.gap = self._gap(run)
        if len(whole) < self.beam_from:  # else the walk, 1-4 s, would only find it too large
            try:
                run.graph = reachable(problem, self.max_operations)
            except TooLarge:
                pass
        # greedy's plan first (module doc, 1-2): from ``greedy_from`` parts, and always for the beam
        if run.graph is None or len(whole) >= self.greedy_from:
            run.start = greedy_start(problem, scorer, scores, stats, self.time_limit)
        run.budget = self._budget(run.start)
        if run.graph is not None:
            stats["search"] = "exact"
            run.plan = self._exact(run)
        else:
            stats["search"] = "beam"
            run.plan = self._beam(run)
        steps = {}
        for sub, op in run.plan.items():
            k = scores.key(op)
            steps[sub] = PlanStep.of(op, "sim" if k in scores.simulated else "model",
                                     score=scores.simulated.get(k),
                                     predicted=scores.predicted.get(k))
        # the refine loop's simulations (greedy's own are ``greedy_simulations``)
        stats["search_simulations"] = scores.simulations - (run.start.known if run.start else 0)
        stats["predicted_operations"] = len(scores.predicted)
        return assembly_order(steps, whole)

    def _gap(self, run: SearchRun) -> float | None:
        """The run's gap (module doc, 4): the option ``gap`` (None: off)."""
        return self.gap

    def _bound(self, run: SearchRun, result: PlanResult) -> dict:
        """The plan's ``bound`` block with its own simulated scores counted (module doc, 5)."""
        scores = run.scores
        scores.add_simulated([s.to_operation() for s in result.steps],
                             [s.score for s in result.steps])
        if run.graph is not None:
            value, scope = self._max_high(run.graph, scores, run.whole), "exact"
        else:
            value, scope = self._beam_value(run), "beam"
        return report(result.robustness, value, self.confidence, scope, scores.bounds,
                      len(result.steps), scores.level)


SearchOptions.planner = SearchPlanner
