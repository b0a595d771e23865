"""One search's run state, passed explicitly to every part of the search that reads or changes it.

A ``SearchRun`` is made for each call of ``SearchPlanner.search`` (``solve`` is ``search(...).plan``)
and handed down as an argument: to the modes (``rap.plan.search.exact``, ``rap.plan.search.beam``),
the refine loop (``rap.plan.search.refine``), the plan's bound and the alternatives
(``rap.plan.search.planner``, ``rap.plan.search.alternatives``). Nothing of a run is kept on the
planner, which one service may share between concurrent requests, nor in a thread-local.

Decisions read the typed fields: ``gap`` (the refine loop's: ``SearchPlanner._gap``, the
planner's option), ``budget (the refine loop's simulations), ``refined`` (what it
spent), ``stopped`` (why it stopped), ``phase1`` (its simulations when phase 2 began) and
``start`` (greedy's first plan). ``stats`` is output only: the search writes its counters there
(the keys the planner's module doc names) and never reads one back to decide.

Preconditions: ``scores`` is set (``SearchPlanner._plan``) before a mode runs. Cost: none (plain
data). No ray, no torch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from rap.plan.graph import Graph
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.scorer import ScorerProtocol
from rap.plan.search.scores import SearchScores
from rap.plan.search.start import Start

__all__ = ["SearchRun", "STOPS"]

#: why the refine loop stopped (``SearchRun.stopped``, ``stats["stopped"]``): the choice settled;
#: the incumbent reached the bound, or came within the gap; the budget or the time limit spent
STOPS = ("settled", "bound", "gap", "budget", "time")


@dataclass
class SearchRun:
    """The state of one search (module doc). ``graph``: the AND/OR graph (exact mode; None in
    beam mode); ``beam``: the final beam's sequences of operations, greedy's and the polished
    plan's among them (beam mode), the scope of the bound and of the alternatives there; ``plan``:
    the chosen plan (subassembly -> operation) once a mode has returned."""

    problem: PlanningProblem
    scorer: ScorerProtocol
    stats: dict = field(default_factory=dict)
    scores: SearchScores | None = None
    graph: Graph | None = None
    beam: list | None = None
    start: Start | None = None
    gap: float | None = None
    budget: int = 0
    refined: int = 0
    stopped: str | None = None
    phase1: int | None = None
    plan: dict | None = None

    @property
    def whole(self) -> frozenset:
        return self.problem.whole

    def stop(self, why: str, **more) -> None:
        """The refine loop stops for ``why`` (one of ``STOPS``); its figures go to ``stats``."""
        if why not in STOPS:
            raise ValueError(f"stopped {why!r}: one of {', '.join(STOPS)}")
        self.stopped = why
        self.stats.update(stopped=why, **more)
