"""The optimum: the most robust sequence over the operation space, by dynamic programming.

``OptimalPlanner`` maximises the product of *simulated* scores, ``best(S) = max over (M, F, d) of
r(op) best(M) best(F)``, ``best({p}) = 1`` (``rap.plan.dp.dp_choice``): every reachable
subassembly and every operation visited once (one simulator batch for the whole graph), against
the paper's exhaustive search over every sequence (``stats["exhaustive_sequences"]`` counts the
assembly trees it would enumerate). The reference the other planners are measured against; its
cost is every operation's simulation. No ray, no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rap.plan.dp import dp_choice, dp_tree
from rap.plan.graph import Interlocked, assembly_order, dead_end, reachable
from rap.plan.planners.base import Planner
from rap.plan.planners.options import PlannerOptions
from rap.plan.report.result import PlanStep

__all__ = ["OptimalPlanner", "OptimalOptions"]


@dataclass(frozen=True)
class OptimalOptions(PlannerOptions):
    """The most robust sequence by dynamic programming over the simulator's scores."""

    method: ClassVar[str] = "optimal"


class OptimalPlanner(Planner):
    """The most robust sequence over the operation space, by dynamic programming (module doc)."""

    name = "optimal"
    options_class = OptimalOptions

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        graph = reachable(problem)
        if not graph[whole]:
            raise Interlocked(whole)
        flat = [op for c in graph.values() for op in c]
        scores = iter(scorer.scores(problem, flat))
        score_of = {s: [next(scores) for _ in c] for s, c in graph.items()}
        best, arg = dp_choice(graph, score_of)
        if best[whole] <= 0.0:
            raise Interlocked(dead_end(graph, whole))
        trees: dict[frozenset, int] = {}

        def t(x):
            return trees.get(x, 0) if len(x) >= 2 else 1

        for s in sorted(graph, key=len):
            trees[s] = sum(t(op.moving) * t(op.fixed) for op in graph[s])
        choice = {sub: PlanStep.of(op, "sim", score=score_of[sub][i])
                  for sub, (i, op) in dp_tree(graph, arg, whole).items()}
        n_ex = trees[whole]
        terms = len(flat)
        stats.update(subassemblies=len(graph), operations=len(flat), dp_evaluations=terms,
                     exhaustive_sequences=n_ex,
                     exhaustive_step_evaluations=n_ex * (len(whole) - 1),
                     dp_speedup=n_ex * (len(whole) - 1) / max(1, terms),
                     predicted_robustness=best[whole])
        return assembly_order(choice, whole)


OptimalOptions.planner = OptimalPlanner
