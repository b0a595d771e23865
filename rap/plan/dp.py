"""The optimum's dynamic program by branch and bound: score only the operations that can matter.

``dp_choice_bounded(graph, scores_of, whole)`` returns what ``rap.plan.graph.dp_choice`` and
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

from rap.plan.graph import Graph, Tree, dp_tree

__all__ = ["dp_choice_bounded", "SLACK"]

SLACK = 1.0 - 1e-9  # prune only below (1 - 1e-9) x the bar: rounding never hides a tie


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
