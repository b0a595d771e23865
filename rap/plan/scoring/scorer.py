"""How planners score operations: one ``Scorer`` over a simulator backend and an optional CNN.

A planner sees one object, ``Scorer``, with two questions:

* ``scores(problem, ops) -> list[float]``: the simulator's score of each operation, in input order.
  Scores already known are taken from the ``ScoreCache`` (content key + root seed, see
  ``rap.plan.scoring.cache``); the rest go to the simulator backend in ONE call, so a backend that runs
  them in parallel (the Ray ``SimPool``, ``rap.serve.planning.PoolSimulator``) sees the whole batch.
* ``prob_high(problem, ops) -> float [N]``: the CNN's P(high) for each operation, one batch;
  ``expected_scores(problem, ops)``: its expected success rate (the binomial head's calibrated
  score; what search multiplies); ``prob_high_and_expected``: both from one pass (what RAP ranks
  by).

**Free operations.** An operation whose moving parts touch no fixed part along the insertion or at
the goal (``PlanningProblem.is_free``, exact) is robust by geometry: both questions answer 1 for
it (score 1, P(high) 1, expected score 1) without asking a backend, and it never enters the
cache, the budget or the CNN's batches (``stats.free`` counts these answers). This is the one
place every planner asks, so every planner (greedy, RAP, the optimum, random, the search) and
every backend (the local simulator, the farm's pool, the CNN, the default cascade) gets it.

Backends: a simulator (``SimBackend``: ``simulate_many(problem, ops) -> list[CachedScore]``), such as
``rap.plan.scoring.local_simulator.LocalSimulator`` (this machine, optionally over forked worker processes)
or the farm's pool; a CNN (``CnnBackend``), such as ``rap.model.inference.operations.OperationPredictor`` (renders
each operation and runs the network, in torch or in numpy). A CNN backend may offer more, each
declared as a protocol of its own and checked with ``isinstance`` (never looked up by name):
``JointCnnBackend`` (both numbers from one pass), ``CalibratedBackend`` (score bounds fitted for
its own numbers) and ``BatchFirstBackend`` (whether a large batch is cheaper than a few at a time);
``rap.model.inference.cascade.CascadeScorer`` offers all three.

**The scorer's protocol.** What planners ask of a scorer is declared once, ``ScorerProtocol``:
the counters, budget and clock (``stats``, ``budget``, ``started``), ``is_free``, the simulator's
``scores`` and ``results``, the CNN's ``prob_high``, ``expected_scores`` and
``prob_high_and_expected``, and what the search plans by: ``bounds`` and ``batch_first``.
``Scorer`` implements it; the planners (``rap.plan.planners``, ``rap.plan.search``) are written
against it.

``on_progress(stats, running)``, when given, is called before each simulator batch (``running``:
its size) and after each batch and CNN call (``running`` 0), with the scorer's counters: what a
command's progress line shows (``rap.commands._progress``).

``Budget`` limits a run (simulations, seconds); a scorer raises ``BudgetSpent`` when a call would
exceed it and the planner reports ``PlanStatus.BUDGET_SPENT``. ``Scorer.fork()`` gives a scorer with
the same backends and cache and fresh counters (one per request in the planning service).

No ray; no torch at import.

Example::

    scorer = Scorer(LocalSimulator(), OperationPredictor.load(model, engine="auto"))
    scores = scorer.scores(problem, problem.candidates(problem.whole))
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Protocol, Sequence, runtime_checkable

import numpy as np

from rap.operation import Operation
from rap.plan.scoring.cache import CachedScore, ScoreCache
from rap.plan.problem import PlanningProblem

if TYPE_CHECKING:
    from rap.model.calibration import ScoreBounds

__all__ = ["SimBackend", "CnnBackend", "JointCnnBackend", "CalibratedBackend", "BatchFirstBackend",
           "ScorerProtocol", "Scorer", "ScorerStats", "Budget", "BudgetSpent"]


_FREE = CachedScore(1.0, 1, 1)  # a free operation's score: exact, by geometry


class SimBackend(Protocol):
    def simulate_many(self, problem: PlanningProblem,
                      ops: Sequence[Operation]) -> list[CachedScore]: ...


class CnnBackend(Protocol):
    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray: ...

    def expected_score(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray: ...


@runtime_checkable
class JointCnnBackend(CnnBackend, Protocol):
    """A CNN backend that gives P(high) and the expected score from one pass."""

    def prob_high_and_expected(self, problem: PlanningProblem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]: ...


@runtime_checkable
class CalibratedBackend(Protocol):
    """A CNN backend that carries the score bounds fitted for its own numbers (None: none)."""

    bounds: ScoreBounds | None


@runtime_checkable
class BatchFirstBackend(Protocol):
    """A CNN backend that says whether a large batch is cheaper than the same operations a few at
    a time (the search then scores the whole graph first)."""

    batch_first: bool


@runtime_checkable
class GuardedBackend(Protocol):
    """A CNN backend with a guard for unfamiliar assemblies: what the plan says when the guard
    acted on ``problem``'s assembly, or None (no guard, or a familiar assembly)."""

    def guard_report(self, problem: PlanningProblem) -> dict | None: ...


class BudgetSpent(Exception):
    """Raised by a scorer when a call would exceed its ``Budget``."""


@dataclass(frozen=True)
class Budget:
    """At most ``max_simulations`` fresh simulations and ``max_seconds`` of wall time (None: no
    limit). The clock starts when the scorer is forked or created."""

    max_simulations: int | None = None
    max_seconds: float | None = None


@dataclass
class ScorerStats:
    sim_requested: int = 0  # operations whose score was asked for
    sim_run: int = 0  # operations simulated fresh (cache misses)
    cache_hits: int = 0
    sim_calls: int = 0  # backend calls (batches)
    sim_seconds: float = 0.0
    sim_trials: int = 0  # trials of the fresh simulations
    cnn_batches: int = 0
    cnn_ops: int = 0
    cnn_seconds: float = 0.0
    free: int = 0  # answers given by geometry (free operations: 1, no backend asked)

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@runtime_checkable
class ScorerProtocol(Protocol):
    """What a planner asks of a scorer (module doc); ``Scorer`` implements it."""

    stats: ScorerStats
    budget: Budget
    started: float  # the clock of ``budget.max_seconds`` and of a planner's time limit

    @property
    def bounds(self) -> ScoreBounds | None:
        """The score bounds fitted for the CNN backend's own numbers, or None (use the CNN's)."""

    @property
    def batch_first(self) -> bool:
        """Whether scoring the whole graph in one batch first is cheaper."""

    def guard_report(self, problem: PlanningProblem) -> dict | None:
        """What the CNN backend's guard did on ``problem``'s assembly, or None (it did not act)."""

    def is_free(self, problem: PlanningProblem, op: Operation) -> bool: ...

    def scores(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[float]: ...

    def results(self, problem: PlanningProblem, ops: Sequence[Operation]
                ) -> list[CachedScore]: ...

    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray: ...

    def expected_scores(self, problem: PlanningProblem, ops: Sequence[Operation]
                        ) -> np.ndarray: ...

    def prob_high_and_expected(self, problem: PlanningProblem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass
class Scorer(ScorerProtocol):
    """Cached simulator scores and CNN probabilities for planners (see module doc)."""

    simulator: SimBackend
    cnn: CnnBackend | None = None
    cache: ScoreCache = field(default_factory=ScoreCache)
    budget: Budget = field(default_factory=Budget)
    stats: ScorerStats = field(default_factory=ScorerStats)
    started: float = field(default_factory=time.perf_counter)
    on_progress: Callable[[ScorerStats, int], None] | None = field(default=None, repr=False)
    #: free operations answer 1 by geometry; False for a replay of recorded score tables, where
    #: the table is the world (research/): every operation is asked of the backends
    free_by_geometry: bool = True

    def is_free(self, problem: PlanningProblem, op: Operation) -> bool:
        """Does this scorer answer the operation by geometry (free, 1)?"""
        return self.free_by_geometry and problem.is_free(op)

    def _progress(self, running: int) -> None:
        if self.on_progress is not None:
            self.on_progress(self.stats, running)

    def fork(self, budget: Budget | None = None, cache: ScoreCache | None = None) -> "Scorer":
        """Same backends (and cache, unless given), fresh counters and clock."""
        return Scorer(self.simulator, self.cnn, self.cache if cache is None else cache,
                      self.budget if budget is None else budget,
                      free_by_geometry=self.free_by_geometry)

    def _check_time(self) -> None:
        b = self.budget
        if b.max_seconds is not None and time.perf_counter() - self.started > b.max_seconds:
            raise BudgetSpent(f"time budget of {b.max_seconds:g} s spent")

    def scores(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[float]:
        """Simulator scores of ``ops`` in input order (cached; misses in one backend call)."""
        return [c.score for c in self.results(problem, ops)]

    def results(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        """``scores`` with their successes and trials; a free operation's is exact, 1 of 1
        (module doc)."""
        self._check_time()
        ops = list(ops)
        free = [self.is_free(problem, op) for op in ops]
        keys = [None if f else problem.key(op) for op, f in zip(ops, free)]
        cached = iter(self.cache.get_many(k for k in keys if k is not None))
        found = [_FREE if f else next(cached) for f in free]
        missing: dict[str, Operation] = {}
        for k, op, c in zip(keys, ops, found):
            if c is None:
                missing.setdefault(k, op)
        st = self.stats
        st.free += sum(free)
        st.sim_requested += len(ops) - sum(free)
        st.cache_hits += len(ops) - sum(free) - sum(1 for c in found if c is None)
        if missing:
            b = self.budget
            if (b.max_simulations is not None
                    and self._spent(problem) + len(missing) > b.max_simulations):
                raise BudgetSpent(f"simulation budget of {b.max_simulations} spent")
            self._progress(len(missing))
            t = time.perf_counter()
            fresh = self.simulator.simulate_many(problem, list(missing.values()))
            st.sim_seconds += time.perf_counter() - t
            st.sim_calls += 1
            st.sim_run += len(missing)
            if len(fresh) != len(missing):
                raise RuntimeError("simulator backend returned a wrong number of results")
            st.sim_trials += sum(c.trials for c in fresh)
            new = dict(zip(missing, fresh))
            self.cache.put_many(new.items())
            found = [c if c is not None else new[k] for k, c in zip(keys, found)]
        self._progress(0)
        return found  # type: ignore[return-value]

    def _spent(self, problem: PlanningProblem) -> float:
        """Fresh simulations so far (what a budget of simulations counts)."""
        return self.stats.sim_run

    @property
    def bounds(self) -> ScoreBounds | None:
        """The score bounds fitted for the CNN backend's own numbers, where it carries them
        (``CalibratedBackend``: ``rap.model.inference.cascade.CascadeScorer.bounds``), else None
        (the CNN's: the shipped ``rap.model.calibration.load()``)."""
        return self.cnn.bounds if isinstance(self.cnn, CalibratedBackend) else None

    @property
    def batch_first(self) -> bool:
        """Whether the CNN backend scores a large batch cheaper than the same operations a few at
        a time (``BatchFirstBackend``: ``rap.model.inference.cascade.CascadeScorer.batch_first``);
        False when it does not say (the CNN: its cost is per operation)."""
        return isinstance(self.cnn, BatchFirstBackend) and bool(self.cnn.batch_first)

    def guard_report(self, problem: PlanningProblem) -> dict | None:
        """What the CNN backend's guard did on ``problem``'s assembly (``GuardedBackend``:
        ``rap.model.inference.cascade.CascadeScorer.guard_report``), else None."""
        return self.cnn.guard_report(problem) if isinstance(self.cnn, GuardedBackend) else None

    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The CNN's P(high) for each operation, one batch. Raises when no CNN is loaded."""
        return self._cnn_call(lambda cnn, p, asked: cnn.prob_high(p, asked), 1, problem, ops)[0]

    def expected_scores(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The CNN's expected score (success rate) for each operation, one batch."""
        return self._cnn_call(lambda cnn, p, asked: cnn.expected_score(p, asked), 1, problem,
                              ops)[0]

    def prob_high_and_expected(self, problem: PlanningProblem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]:
        """Both of the CNN's numbers for each operation, one batch (one rendering and forward
        pass where the backend offers it, ``JointCnnBackend``, else two calls)."""
        if self.cnn is not None and not isinstance(self.cnn, JointCnnBackend):
            return self.prob_high(problem, ops), self.expected_scores(problem, ops)
        return self._cnn_call(lambda cnn, p, asked: cnn.prob_high_and_expected(p, asked), 2,
                              problem, ops)

    def _cnn_call(self, call: Callable, width: int, problem: PlanningProblem,
                  ops: Sequence[Operation]) -> tuple[np.ndarray, ...]:
        """``call(cnn, problem, asked)`` on the operations that are not free, its ``width``
        arrays spread back over ``ops`` (free ones: 1)."""
        if self.cnn is None:
            raise RuntimeError("this scorer has no CNN (load a model for methods rap and search)")
        self._check_time()
        ops = list(ops)
        free = np.array([self.is_free(problem, op) for op in ops], dtype=bool)
        asked = [op for op, f in zip(ops, free) if not f]
        out = tuple(np.ones(len(ops), dtype=np.float64) for _ in range(width))
        self.stats.free += int(free.sum())
        if asked:  # free operations: 1 by geometry, never shown to the model (module doc)
            t = time.perf_counter()
            got = call(self.cnn, problem, asked)
            self.stats.cnn_seconds += time.perf_counter() - t
            self.stats.cnn_batches += 1
            self.stats.cnn_ops += len(asked)
            self._progress(0)
            got = tuple(np.asarray(x, dtype=np.float64) for x in
                        (got if isinstance(got, tuple) else (got,)))
            if len(got) != width or any(x.shape != (len(asked),) for x in got):
                raise RuntimeError(f"CNN returned shape {[x.shape for x in got]} for "
                                   f"{len(asked)} operations")
            for x, y in zip(out, got):
                x[~free] = y
        return out
