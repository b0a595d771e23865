"""Scoring the whole AND/OR graph in one batch before the search, whatever the scorer
(``SearchPlanner(lazy=False)`` before 0.3.0): the same plans as the lazy search (``rap.plan.dp``'s
branch and bound asks for a subassembly's scores only when it can matter). With the CNN alone it
is slower (1.47x), so the shipped search does it only for a scorer whose batches are cheaper
(``Scorer.batch_first``: the default scorer, 0.59x); ``python -m research.benchmarks.search
--engine cnn|auto`` measures both."""

from __future__ import annotations

from rap.plan.search.planner import SearchPlanner

__all__ = ["EagerSearchPlanner"]


class EagerSearchPlanner(SearchPlanner):
    """The search with every operation of the graph predicted first, in one batch."""

    def _exact(self, run):
        run.scores.predict([op for c in run.graph.values() for op in c])
        return super()._exact(run)
