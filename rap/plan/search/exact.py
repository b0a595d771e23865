"""The search's exact mode: branch and bound over the whole AND/OR graph of reachable subassemblies.

``ExactMode`` is a part of ``rap.plan.search.planner.SearchPlanner`` (a mixin, with
``rap.plan.search.refine.RefineLoop``). ``_exact(run)`` (the search's run state,
``rap.plan.search.run.SearchRun``, with its ``graph``) chooses by the optimum's DP (``rap.plan.dp.dp_choice_bounded``: a subassembly's candidates are predicted only
on its first visit, when they can still matter; with a scorer whose batches are cheaper,
``Scorer.batch_first``, the whole graph is predicted in one batch first, the same scores and
plans) and refines the choice with simulations. An interlocked subassembly is a dead end (value 0);
when every choice ends in one, ``Interlocked`` names it. When the budget (or the time limit)
stopped the refine loop, the plan's remaining steps are simulated and the best fully simulated
sequence is returned (``_best_simulated``: it may combine subtrees of several simulated plans,
greedy's among them; stats ``final``, ``final_simulations``). ``_max_high`` is ``V``, the best
product of upper bounds (simulated scores where known) over every sequence of the graph.

Stats: ``subassemblies``, ``operations`` (the graph's). Cost: one scorer batch per subassembly
visited (65-71% of the graph's operations on held-out assemblies with the CNN), or one for the
whole graph where the scorer says that is cheaper; the refine loop's simulations; a DP over the
graph per round (three when watching the bound: the choice's, ``V``'s and the incumbent's). No
ray, no torch.
"""

from __future__ import annotations

import math

from rap.plan.dp import dp_choice_bounded, max_value
from rap.plan.graph import Interlocked, dead_end
from rap.plan.scoring.scorer import BudgetSpent
from rap.plan.search.run import SearchRun
from rap.plan.search.scores import SearchScores, incumbent

__all__ = ["ExactMode"]


class ExactMode:
    """The exact mode (module doc); mixed into ``SearchPlanner``."""

    def _exact(self, run: SearchRun) -> dict:
        graph, scores, whole = run.graph, run.scores, run.whole
        run.stats.update(subassemblies=len(graph), operations=sum(len(c) for c in graph.values()))
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
            run, choose,
            lambda best: best if self._free_bound(scores) else self._max_high(graph, scores, whole),
            lambda: incumbent(graph, scores, whole))
        if run.stopped not in ("budget", "time") or not run.budget:
            return plan  # settled; or the model alone (no simulation while planning)
        return self._best_simulated(run, plan)

    @staticmethod
    def _best_simulated(run: SearchRun, plan: dict) -> dict:
        """When the budget stopped the search (the planner's module doc, 3): the chosen plan's
        steps not yet simulated are simulated (its evaluation would simulate them anyway), and the
        best fully simulated sequence is returned: the plan, or a better one combining the
        subtrees simulated so far (greedy's plan among them). A plan with trusted or unsimulated
        steps (the scorer's own budget spent) is kept unless a simulated sequence beats it."""
        scores = run.scores
        before = scores.simulations
        try:
            scores.simulate(plan.values())
        except BudgetSpent:
            pass
        run.stats["final_simulations"] = scores.simulations - before
        got, got_plan = incumbent(run.graph, scores, run.whole)
        mine = math.prod(scores.known(op) for op in plan.values())
        if got_plan is None or got <= mine:
            return plan
        run.stats.update(final="incumbent", predicted_robustness=got)
        return got_plan

    @staticmethod
    def _max_high(graph, scores: SearchScores, whole) -> float:
        """``V``: the best product of upper bounds (simulated scores where known)."""
        def scores_of(s):
            if scores.bounds.calibrated:  # uncalibrated: every bound is 1, no CNN needed
                scores.predict(graph[s])
            return scores.scores("high", s, graph[s])

        return max_value(graph, scores_of, whole, scores.memo("high"))
