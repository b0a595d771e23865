"""The dynamic programmes over the AND/OR graph: the best product of scores below a subassembly.

Every planner that maximises a product of step scores over sequences does it here
(``best(S) = max over candidates of r(op) best(M) best(F)``, ``best`` of a single part 1, of a
dead end 0; ties to the first candidate in the problem's order, ``argmax_first``):

* ``dp_choice(graph, score_of)``: every subassembly, smallest first, with every score given
  (the optimum's DP over simulated scores); ``dp_tree`` the tree its choice picks. O(operations).
  ``objective="attempts"`` minimises instead the expected number of attempts when a failed step
  is retried until it succeeds, ``best(S) = min over candidates of 1/r(op) + best(M) + best(F)``
  (``best`` of a single part 0; an operation scoring 0 is infinite, a dead end; ties to the
  first minimising candidate), additive over the tree as the product is multiplicative.
* ``dp_choice_bounded(graph, scores_of, whole)``: the same choice by branch and bound, asking for
  scores only where they can matter (the search's DP over predicted scores; below).
* ``max_value(graph, scores_of, whole)``: the best value alone, ties pruned (the search's bound).

Example::

    graph = reachable(problem)                 # rap.plan.graph
    best, arg = dp_choice(graph, {s: [1.0] * len(c) for s, c in graph.items()})
    tree = dp_tree(graph, arg, problem.whole)   # {subassembly: (index, operation)}

Branch and bound (``dp_choice_bounded``):
``dp_choice_bounded(graph, scores_of, whole)`` returns what ``dp_choice`` and
``dp_tree`` give for ``whole`` (``best(S) = max r(op) best(M) best(F)``, the first maximising
candidate in ``graph[S]`` order; the same floats, multiplied in the same order), but asks for the
scores of a subassembly's candidates (``scores_of(S)``) only when it visits ``S``, and visits ``S``
only when it can still matter: scores lie in [0, 1], so an operation whose score is already below
the best value found (or below what its parent needs) cannot be chosen, and neither can anything
reached only through it. Candidates are tried in decreasing score order, so a good sequence is
found early and prunes the rest.

``value(S, tau)`` returns ``best(S)`` exactly when it exceeds ``tau``, else an upper bound no
larger than ``tau`` (marked as such, never mistaken for a value); pruning compares with a relative
slack of ``SLACK`` so that rounding never prunes a candidate that ties with the best (ties must be
seen to keep the first maximiser). Memory: O(subassemblies visited). A search that solves it
again after a few scores changed keeps the values below the changes (``memo``).

Cost: at most the full DP's work (every subassembly's candidates scored once); how much less
depends on how the scores are spread, not on whether they are right (measured: docs/RESULTS.md,
``python -m research.benchmarks.search``). Recursion depth at most the number of parts.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

from rap.plan.graph import Graph, Tree
from rap.stats import expected_attempts

__all__ = ["dp_choice", "dp_tree", "dp_choice_bounded", "max_value", "argmax_first", "SLACK",
           "OBJECTIVES"]

#: what ``dp_choice`` optimises: the product of scores (R, maximised) or the expected attempts
#: (the sum of 1/r, minimised); the first is the default everywhere
OBJECTIVES = ("robustness", "attempts")

SLACK = 1.0 - 1e-9  # prune only below (1 - 1e-9) x the bar: rounding never hides a tie


def argmax_first(values: Sequence[float]) -> int:
    """The index of the largest value, the first one on ties (0 for an empty sequence)."""
    best, idx = -float("inf"), 0
    for i, v in enumerate(values):
        if v > best:
            best, idx = v, i
    return idx


def dp_choice(graph: Graph, score_of: dict[frozenset, Sequence[float]],
              objective: str = "robustness") -> tuple[dict, dict]:
    """``best(S) = max over candidates of r(op) * best(M) * best(F)`` (``best`` of a single part:
    1; of a dead end: 0) for every subassembly of ``graph``, smallest first; ``arg[S]`` the index
    of the first maximising candidate. ``score_of[S]``: the scores of ``graph[S]`` in order.
    ``objective="attempts"``: ``best(S) = min of 1/r(op) + best(M) + best(F)`` instead (a single
    part 0; a dead end or a score of 0 infinite; the first minimising candidate; module doc).
    ``ValueError`` for another objective. O(operations)."""
    if objective == "attempts":
        return _dp_attempts(graph, score_of)
    if objective != "robustness":
        raise ValueError(f"objective {objective!r}: choose one of {', '.join(OBJECTIVES)}")
    best: dict[frozenset, float] = {}
    arg: dict[frozenset, int] = {}

    def b(x):
        return best.get(x, 0.0) if len(x) >= 2 else 1.0

    for s in sorted(graph, key=len):
        vals = [r * b(op.moving) * b(op.fixed) for op, r in zip(graph[s], score_of[s])]
        if not vals:
            best[s] = 0.0
            continue
        i = argmax_first(vals)
        best[s], arg[s] = vals[i], i
    return best, arg


def _dp_attempts(graph: Graph, score_of: dict[frozenset, Sequence[float]]) -> tuple[dict, dict]:
    """``dp_choice`` for the expected attempts: the sum of ``1/r`` minimised (module doc)."""
    best: dict[frozenset, float] = {}
    arg: dict[frozenset, int] = {}

    def b(x):
        return best.get(x, math.inf) if len(x) >= 2 else 0.0

    for s in sorted(graph, key=len):
        vals = [expected_attempts(r) + b(op.moving) + b(op.fixed)
                for op, r in zip(graph[s], score_of[s])]
        i = argmax_first([-v for v in vals])
        if not vals or vals[i] == math.inf:
            best[s] = math.inf  # a dead end: no sequence with every step possible
            continue
        best[s], arg[s] = vals[i], i
    return best, arg


def dp_tree(graph: Graph, arg: dict[frozenset, int], whole: frozenset) -> Tree:
    """The disassembly tree that ``arg`` (from ``dp_choice``) picks below ``whole``: subassembly ->
    (candidate index, operation) for every composite subassembly of it. O(parts)."""
    tree: Tree = {}
    stack = [whole]
    while stack:
        s = stack.pop()
        if len(s) < 2:
            continue
        op = graph[s][arg[s]]
        tree[s] = (arg[s], op)
        stack += [op.moving, op.fixed]
    return tree


def dp_choice_bounded(graph: Graph, scores_of: Callable[[frozenset], Sequence[float]],
                      whole: frozenset, memo: tuple[dict, dict] | None = None
                      ) -> tuple[float, Tree]:
    """``(best(whole), tree)``: ``tree`` maps every composite subassembly of the chosen
    decomposition to ``(candidate index, operation)``, as ``dp_tree(graph, dp_choice(...)[1],
    whole)``; ``(0.0, {})`` when no sequence exists (best 0), ``(1.0, {})`` for a single part.
    ``scores_of(S)``: the scores in [0, 1] of ``graph[S]`` in order (asked once per visit of
    ``S``; a subassembly first bounded is visited again when a lower bar needs its value).
    ``memo``: ``(exact, bound)``, what earlier calls with the same scores found (each entry
    depends only on the scores of the subassemblies below it), used and filled in; a caller whose
    scores change drops the entries of every subassembly containing one whose scores changed."""
    exact: dict[frozenset, tuple[float, int]]
    bound: dict[frozenset, float]
    exact, bound = memo if memo is not None else ({}, {})

    def value(s: frozenset, tau: float) -> tuple[float, bool]:
        if len(s) < 2:
            return 1.0, True
        if s in exact:
            return exact[s][0], True
        if s in bound and bound[s] <= tau:
            return bound[s], False
        cands = graph[s]
        if not cands:
            exact[s] = (0.0, -1)
            return 0.0, True
        scores = list(scores_of(s))
        best, arg = -math.inf, -1
        for i in sorted(range(len(cands)), key=lambda j: (-scores[j], j)):
            r = scores[i]
            cut = max(best, tau)
            if cut > 0 and r < cut * SLACK:
                break  # sorted: every later candidate scores no more
            op = cands[i]
            if r > 0:
                vm, ok = value(op.moving, cut / r * SLACK if cut > 0 else -1.0)
                if not ok or (cut > 0 and r * vm < cut * SLACK):
                    continue
                if r * vm > 0:
                    vf, ok = value(op.fixed, cut / (r * vm) * SLACK if cut > 0 else -1.0)
                    if not ok:
                        continue
                    val = r * vm * vf
                else:
                    val = r * vm * 0.0  # a dead end below: 0, whatever the other side
            else:
                val = 0.0
            if val > best or (val == best and i < arg):
                best, arg = val, i
        if best > tau:
            exact[s] = (best, arg)
            return best, True
        bound[s] = tau
        return tau, False

    if len(whole) < 2:
        return 1.0, {}
    best, _ = value(whole, -1.0)
    if best <= 0.0:
        return 0.0, {}  # no sequence: the caller names the dead end (``dead_end``)
    return best, dp_tree(graph, {s: i for s, (_, i) in exact.items()}, whole)


def max_value(graph: Graph, scores_of, whole: frozenset,
              memo: tuple[dict, dict] | None = None) -> float:
    """``max over sequences of the product of scores`` below ``whole`` (1 for a single part, 0
    when none exists); ``scores_of(S)``: the scores in [0, 1] of ``graph[S]`` in order, asked at
    most once per subassembly. Branch and bound as ``rap.plan.dp``, but a candidate that
    can at most tie is pruned (only the value is wanted). Recursion depth at most the parts.
    ``memo``: ``(exact, bounded)`` kept between calls, as ``dp_choice_bounded``'s."""
    exact: dict[frozenset, float]
    bounded: dict[frozenset, float]
    exact, bounded = memo if memo is not None else ({}, {})
    asked: dict[frozenset, list] = {}

    def value(s: frozenset, tau: float) -> tuple[float, bool]:
        # best(s) exactly when it exceeds tau; else (a number <= tau that is >= best(s), False)
        if len(s) < 2:
            return 1.0, True
        if s in exact:
            return exact[s], True
        if s in bounded and bounded[s] <= tau:
            return bounded[s], False
        cands = graph[s]
        if s not in asked:
            asked[s] = list(scores_of(s)) if cands else []
        scores = asked[s]
        best = 0.0
        for i in sorted(range(len(cands)), key=lambda j: -scores[j]):
            r = scores[i]
            cut = max(best, tau)
            if r <= cut or r <= 0.0:
                break  # sorted: nothing later can beat the cut
            vm, ok = value(cands[i].moving, cut / r)
            if not ok or r * vm <= cut:
                continue
            vf, ok = value(cands[i].fixed, cut / (r * vm))
            if ok and r * vm * vf > best:
                best = r * vm * vf
        if best > tau:
            exact[s] = best
            return best, True
        bounded[s] = max(tau, 0.0)
        return bounded[s], False

    if len(whole) < 2:
        return 1.0
    v, ok = value(whole, -1.0)
    return v if ok else 0.0
