"""The search's other plans: up to K distinct complete plans beside its best, from what it knows.

``SearchPlanner.search(problem, scorer)`` returns a ``SearchOutcome``: ``plan``, the search's plan
(the ``PlanResult`` that ``solve`` returns, the same whatever the option ``alternatives``), and, with
``alternatives`` = K > 0, ``alternatives``: up to K other complete plans, best first by
``estimates``, their products of scores as the search knows them after the plan's evaluation
(``SearchScores.known``: the simulator's score where known, else the model's expected score).

* **Exact mode**: ``k_best(graph, scores_of, whole, k)``, the ``k`` best disassembly trees of the
  AND/OR graph by product of scores: a K-best dynamic programme (each subassembly keeps its ``k``
  best trees, combined from its candidates' and its sides' lists), by branch and bound as
  ``rap.plan.dp.dp_choice_bounded``: a candidate whose score is no more than the ``k``-th best
  product found cannot enter the list, nor can anything reached only through it. Trees of product
  0 (a dead end, or a step that never succeeds) are not plans and never listed.
* **Beam mode**: the final beam's complete sequences (greedy's and the polished plan among them:
  ``SearchRun.beam``), at most the beam's width + 2.

Distinct: no two alternatives have the same steps, and none has the plan's. Each is a tree
written in assembly order as the plan is (``rap.plan.graph.assembly_order``), so distinct trees are
distinct step sequences. Ties keep the first found (the candidates' order; the beam's).

Each alternative is a ``PlanResult`` (status ``FOUND``, the search's method and assembly): a
step's ``score`` is the simulator's where the search knows it (``source`` ``sim``; ``free``: 1 by
geometry), else None (``source`` ``model``, ``predicted`` the model's expected score);
``robustness`` the product of the step scores when all are known, else None. They are not
annotated (no robot moves, intervals or reasons): ``rap.plan.planners.base.evaluate_steps`` then
``rap.plan.report.poses.annotate_plan`` make one a full plan, at the cost of simulating its
unsimulated steps.

Cost: no simulation. Exact: the K-best DP visits only the subassemblies through which a tree can
still enter the K best (more than the search's own DP, whose bar is the best product, not the
K-th), ``k`` x ``k`` combinations per candidate at most; a visited subassembly whose candidates the search neither predicted nor simulated is predicted in
one scorer batch (none with a batch-first scorer, which predicted the whole graph; one batch per
such subassembly with the CNN alone). Beam: products over the beam's sequences. Measured with K =
8 (``SearchPlanner(alternatives=8).search`` against ``alternatives=0``, 20 trials,
a 2-core machine shared with other work): 7-22 ms with the shipped scorer and no CNN call
(hexagon, triangles, packing-s100, a beam on herringbone 18); with the CNN alone 7 ms to 3.5 s
(packing-s100: 22 more CNN batches, 78 operations). No ray, no torch.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Callable, Sequence

from rap.plan.dp import SLACK
from rap.plan.graph import Graph, assembly_order
from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
from rap.plan.search.run import SearchRun

__all__ = ["SearchOutcome", "k_best", "alternatives"]

_LEAF = (1.0, None, None, None)  # a single part: the empty tree, product 1


@dataclass(frozen=True)
class SearchOutcome:
    """What ``SearchPlanner.search`` returns (module doc): ``plan``; ``alternatives``, other
    distinct complete plans, best first; ``estimates``, their products of known scores (one per
    alternative, non-increasing)."""

    plan: PlanResult
    alternatives: tuple[PlanResult, ...] = ()
    estimates: tuple[float, ...] = ()


def k_best(graph: Graph, scores_of: Callable[[frozenset], Sequence[float]], whole: frozenset,
           k: int) -> list[tuple[float, dict]]:
    """The ``k`` best trees below ``whole`` by product of scores, best first: ``(product,
    {subassembly: operation})``, only products above 0 (module doc); ``[(1.0, {})]`` for a single
    part. ``scores_of(S)``: the scores in [0, 1] of ``graph[S]`` in order, asked at most once per
    subassembly. The best tree's product is ``dp_choice``'s value; on ties the first candidate in
    ``graph[S]`` order comes first. Recursion depth at most the number of parts."""
    if k < 1:
        return []
    # subassembly -> (tau, entries): every tree of S with product above tau, at most the k best,
    # best first; an entry is (product, operation, moving side's entry, fixed side's entry)
    lists: dict[frozenset, tuple[float, list]] = {}
    asked: dict[frozenset, list[float]] = {}

    def best(s: frozenset, tau: float) -> list:
        if len(s) < 2:
            return [_LEAF]
        hit = lists.get(s)
        if hit is not None and hit[0] <= tau:
            return hit[1]
        cands = graph[s]
        if s not in asked:
            asked[s] = list(scores_of(s)) if cands else []
        scores = asked[s]
        # (product, order, entry), order the negated (candidate, moving rank, fixed rank): the k
        # best so far with the weakest on top, the later of two equal products the weaker
        heap: list = []

        def out(v: float) -> bool:  # v, and anything below it, cannot enter the list
            return v <= tau or (len(heap) == k and v < heap[0][0] * SLACK)

        def bar() -> float:
            return max(tau, heap[0][0]) if len(heap) == k else tau

        for i in sorted(range(len(cands)), key=lambda j: (-scores[j], j)):
            r = scores[i]
            if out(r):
                break  # sorted: no tree through a later candidate can enter either
            op = cands[i]
            ms = best(op.moving, bar() / r * SLACK)
            if not ms:
                continue
            fs = best(op.fixed, bar() / (r * ms[0][0]) * SLACK)
            for mi, m in enumerate(ms):
                rm = r * m[0]
                if out(rm):
                    break
                for fi, f in enumerate(fs):
                    v = rm * f[0]  # r * a * b, multiplied as the DP does
                    if out(v):
                        break
                    item = (v, (-i, -mi, -fi), (v, op, m, f))
                    if len(heap) < k:
                        heapq.heappush(heap, item)
                    elif item[:2] > heap[0][:2]:
                        heapq.heapreplace(heap, item)
        entries = [e for _, _, e in sorted(heap, key=lambda x: (-x[0], [-n for n in x[1]]))]
        lists[s] = (tau, entries)
        return entries

    def tree(entry, out: dict) -> dict:
        stack = [entry]
        while stack:
            _, op, m, f = stack.pop()
            if op is not None:
                out[op.moving | op.fixed] = op
                stack += [m, f]
        return out

    if len(whole) < 2:
        return [(1.0, {})]
    return [(e[0], tree(e, {})) for e in best(whole, 0.0)]


def _as_plan(run: SearchRun, plan: PlanResult, choice: dict) -> PlanResult:
    """One alternative tree (subassembly -> operation) as a ``PlanResult`` (module doc)."""
    scores = run.scores
    steps = {}
    for sub, op in choice.items():
        key = scores.key(op)
        source = "free" if key in scores.free else "sim" if key in scores.simulated else "model"
        steps[sub] = PlanStep.of(op, source, score=scores.simulated.get(key),
                                 predicted=scores.predicted.get(key))
    ordered = tuple(assembly_order(steps, run.whole))
    known = [s.score for s in ordered]
    r = None if any(x is None for x in known) else float(math.prod(known))
    return PlanResult(PlanStatus.FOUND, plan.method, plan.assembly, ordered, r, units=plan.units)


def _predict(run: SearchRun, ops) -> None:
    """The model's scores of those of ``ops`` that the search neither simulated nor predicted."""
    run.scores.predict([op for op in ops if not run.scores.is_simulated(op)])


def alternatives(run: SearchRun, plan: PlanResult, k: int) -> SearchOutcome:
    """``plan`` (found, evaluated: its scores are known to ``run.scores``) with up to ``k`` other
    distinct complete plans of ``run`` (module doc)."""
    if k < 1 or not plan.found or not plan.steps:
        return SearchOutcome(plan)
    scores = run.scores
    mine = frozenset(scores.key(s.to_operation()) for s in plan.steps)
    if run.graph is not None:
        graph = run.graph

        def scores_of(s):
            _predict(run, graph[s])  # nothing to do where the search predicted them
            return [scores.known(op) for op in graph[s]]

        found = k_best(graph, scores_of, run.whole, k + 1)
    else:
        seqs = run.beam or []
        _predict(run, [op for seq in seqs for op in seq])
        found = sorted(((math.prod(scores.known(op) for op in seq), i, seq)
                        for i, seq in enumerate(seqs)), key=lambda x: (-x[0], x[1]))
        found = [(v, {op.moving | op.fixed: op for op in seq}) for v, _, seq in found if v > 0]
    out, seen = [], {mine}
    for value, choice in found:
        keys = frozenset(scores.key(op) for op in choice.values())
        if keys in seen:
            continue
        seen.add(keys)
        out.append((value, choice))
        if len(out) == k:
            break
    return SearchOutcome(plan, tuple(_as_plan(run, plan, c) for _, c in out),
                         tuple(v for v, _ in out))
