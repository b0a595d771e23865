"""Scoring the whole AND/OR graph in one CNN batch before the search (``SearchPlanner(lazy=False)``
before 0.3.0): the same plans as the shipped lazy search (``rap.plan.dp``'s branch and bound asks
for a subassembly's scores only when it can matter), measured slower (research/README.md,
``python -m research.benchmarks.search``)."""

from __future__ import annotations

from rap.plan.search.planner import SearchPlanner

__all__ = ["EagerSearchPlanner"]


class EagerSearchPlanner(SearchPlanner):
    """The search with every operation of the graph predicted first, in one batch."""

    def _exact(self, graph, scores, whole, stats, budget):
        scores.predict([op for c in graph.values() for op in c])
        return super()._exact(graph, scores, whole, stats, budget)
