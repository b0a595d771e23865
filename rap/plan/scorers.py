"""How planners score operations: one ``Scorer`` over a simulator backend and an optional CNN.

A planner sees one object, ``Scorer``, with two questions:

* ``scores(problem, ops) -> list[float]``: the simulator's score of each operation, in input order.
  Scores already known are taken from the ``ScoreCache`` (content key + root seed, see
  ``rap.plan.cache``); the rest go to the simulator backend in ONE call, so a backend that runs
  them in parallel (the Ray ``SimPool``, ``rap.farm.service.PoolSimulator``) sees the whole batch.
* ``prob_high(problem, ops) -> float [N]``: the CNN's P(high) for each operation, one batch;
  ``expected_scores(problem, ops)``: its expected success rate (the binomial head's calibrated
  score; what search multiplies); ``prob_high_and_expected``: both from one pass (what RAP ranks
  by).

Simulator backends (``SimBackend``: ``simulate_many(problem, ops) -> list[CachedScore]``):
``LocalSimulator`` runs ``rap.sim.simulator.simulate`` on this machine with the per-operation seed
``problem.seed(op)`` (the labelling farm's seed, so the scores equal the dataset's labels for the
same parameters and root seed): in this process, or, with ``processes > 1``, a batch of at least
``min_batch`` (``MIN_PROCESS_BATCH``, 8) operations spread over that many forked worker processes,
started at the first such batch (well under a second, against 10-30 s for a local Ray) and kept
until ``close()``. With ``prestart=True`` the workers are forked at once and load the compiled
simulator while the caller plans (a one-off ``rap-farm plan``: the ~0.75 s of loading and the
~0.35 s that an interpreter which loaded numba takes to exit stay off the planner's core); every
batch then goes to them.
CNN backend: ``PredictorCnn`` renders each operation (``rap.render.images.render_pair``) and asks a
predictor: ``rap.model.predict.Predictor`` (torch), or with ``engine="auto"`` the torch-free
forward pass of ``rap.plan.fastcnn`` when it runs the checkpoint exactly (no torch import: seconds
saved for a one-off plan).

``Budget`` limits a run (simulations, seconds); a scorer raises ``BudgetSpent`` when a call would
exceed it and the planner reports ``PlanStatus.BUDGET_SPENT``. ``Scorer.fork()`` gives a scorer with
the same backends and cache and fresh counters (one per request in the planning service).

No ray; no torch at import.
"""

from __future__ import annotations

import sys
import threading
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol, Sequence

import numpy as np

from rap.operation import Operation
from rap.plan.cache import CachedScore, ScoreCache
from rap.plan.problem import PlanningProblem

__all__ = ["SimBackend", "CnnBackend", "LocalSimulator", "PredictorCnn", "Scorer", "ScorerStats",
           "Budget", "BudgetSpent", "IMAGE_SIZE", "model_familiarity", "foreground_stats",
           "familiarity_operations", "FAMILIARITY_OPERATIONS"]

IMAGE_SIZE = 64
#: the smallest batch that ``LocalSimulator`` spreads over worker processes: each new worker loads
#: the compiled simulator (~0.3 s) and competes with the planner for the cores, so a handful of
#: operations (a greedy plan's evaluation: one per step) is simulated faster in the process itself
MIN_PROCESS_BATCH = 8
#: niceness of prestarted workers: while they load the simulator the parent plans on the same
#: cores and comes first (a warm score cache needs no simulation at all: 1.9 s instead of 2.4 s
#: for a 7-part plan on 2 cores); once the parent waits for their results they have the machine
WARM_NICE = 10
#: images per forward pass while ``PredictorCnn.cores_busy`` is consulted (a multiple of
#: ``rap.plan.fastcnn.CHUNK``, so that the passes are the same)
SHARE_CHUNK = 256


class SimBackend(Protocol):
    def simulate_many(self, problem: PlanningProblem,
                      ops: Sequence[Operation]) -> list[CachedScore]: ...


class CnnBackend(Protocol):
    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray: ...

    def expected_score(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray: ...


class BudgetSpent(Exception):
    """Raised by a scorer when a call would exceed its ``Budget``."""


@dataclass(frozen=True)
class Budget:
    """At most ``max_simulations`` fresh simulations and ``max_seconds`` of wall time (None: no
    limit). The clock starts when the scorer is forked or created."""

    max_simulations: int | None = None
    max_seconds: float | None = None


def _simulate_one(simulate: Callable | None, assembly, op, params, seed: int) -> CachedScore:
    if simulate is None:
        from rap.sim.simulator import simulate
    res = simulate(assembly, op, params, np.random.default_rng(seed))
    return CachedScore(float(res.score), int(res.successes), int(res.trials))


def _simulate_task(args) -> CachedScore:  # runs in a worker process
    return _simulate_one(None, *args)


def _worker_init(warmed=None) -> None:
    """Worker processes leave Ctrl-C to the parent, which stops them (no traceback per worker);
    with a shared counter ``warmed``, load the compiled simulator now rather than at the first
    operation (at a lower priority), then count this worker as warm."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if warmed is not None:
        import os

        os.nice(WARM_NICE)
        from rap.sim.simulator import warm_up

        warm_up()
        with warmed.get_lock():
            warmed.value += 1


def _noop() -> None:  # submitted once to make a fork pool start its workers
    return None


class LocalSimulator:
    """``rap.sim.simulator.simulate`` on this machine (``simulate`` replaceable): sequentially in
    this process, or over ``processes`` forked workers for batches of ``min_batch`` or more
    operations (Linux; the real simulator only); with ``prestart``, over ``processes`` workers (one
    or more) forked now, which load the simulator at once and take every batch. Same seeds, same
    scores either way. A pool that breaks (a worker killed) is dropped and the batch simulated
    here."""

    def __init__(self, simulate: Callable | None = None, *, processes: int = 1,
                 min_batch: int = MIN_PROCESS_BATCH, prestart: bool = False):
        self._simulate = simulate
        self.processes = max(1, int(processes))
        self.min_batch = max(1, int(min_batch))
        self._executor = None
        self._lock = threading.Lock()
        self._warmed = None  # shared count of prestarted workers that have loaded the simulator
        self.prestarted = bool(prestart) and self._can_fork()
        if self.prestarted:
            self._pool().submit(_noop)  # a fork pool starts all its workers at the first submit

    def loading(self) -> bool:
        """True while prestarted workers are still loading the simulator (the caller then leaves
        them a core: see ``PredictorCnn.cores_busy``)."""
        warmed = self._warmed
        return self.prestarted and warmed is not None and warmed.value < self.processes

    def _can_fork(self) -> bool:
        return self._simulate is None and sys.platform.startswith("linux")

    def _pool(self):
        if not self._can_fork() or (self.processes < 2 and not self.prestarted):
            return None
        with self._lock:
            if self._executor is None:
                import multiprocessing
                from concurrent.futures import ProcessPoolExecutor

                ctx = multiprocessing.get_context("fork")
                if self.prestarted:
                    self._warmed = ctx.Value("i", 0)
                else:
                    from rap.sim import simulator  # noqa: F401  (imported once, before the fork)
                self._executor = ProcessPoolExecutor(self.processes, mp_context=ctx,
                                                     initializer=_worker_init,
                                                     initargs=(self._warmed,))
            return self._executor

    def simulate_many(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        jobs = [(problem.assembly, op, problem.params, problem.seed(op)) for op in ops]
        pool = self._pool() if self.prestarted or len(jobs) >= self.min_batch else None
        if pool is not None:
            from concurrent.futures.process import BrokenProcessPool

            try:
                return list(pool.map(_simulate_task, jobs))
            except BrokenProcessPool:
                self.close()
                self.prestarted, self.processes = False, 1
        return [_simulate_one(self._simulate, *j) for j in jobs]

    def close(self) -> None:
        """Stop the worker processes (if any were started). Workers still loading the simulator
        are terminated rather than waited for: they hold nothing that must be kept."""
        with self._lock:
            ex, self._executor = self._executor, None
        if ex is None:
            return
        terminate = getattr(ex, "terminate_workers", None)  # Python >= 3.14
        if terminate is not None:
            terminate()
            return
        processes = list((getattr(ex, "_processes", None) or {}).values())
        manager = getattr(ex, "_executor_manager_thread", None)
        ex.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            proc.terminate()
        for proc in processes:
            proc.join()
        # The executor's manager thread joins the same workers; until it has returned, a worker it
        # reaped can still read as alive here (waitpid's ECHILD race), so wait for it too.
        if manager is not None:
            manager.join(timeout=10)


class PredictorCnn:
    """A loaded robustness CNN (``rap.model.predict.Predictor``) plus the renderer.

    ``render(assembly, op, size=64) -> uint8 [2, 64, 64]`` defaults to
    ``rap.render.images.render_pair``.

    ``cores_busy``: optional ``() -> bool``, asked before each ``SHARE_CHUNK`` images of the numpy
    engine: while it says True the forward pass runs BLAS on one thread (threadpoolctl), leaving
    the other cores to processes that share the machine (``LocalSimulator.loading``: prestarted
    simulation workers; OpenBLAS's second thread spins between calls and starves them). Same
    results either way."""

    def __init__(self, predictor, render: Callable | None = None):
        self.predictor = predictor
        self._render = render
        self._lock = threading.Lock()  # one forward pass at a time (torch threads are shared)
        self.render_seconds = 0.0
        self.cores_busy: Callable[[], bool] | None = None
        self._threadpools = None
        self._contexts: dict = {}  # geometry hash -> DescriptorContext (a few recent assemblies)
        self._contexts_lock = threading.Lock()

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", engine: str = "torch",
             mirror: bool = False) -> "PredictorCnn":
        """``engine``: ``"torch"`` (``rap.model.predict.Predictor``) or ``"auto"``: on the CPU,
        ``rap.plan.fastcnn``'s numpy forward pass when it runs this checkpoint exactly, else torch.
        Both give the same probabilities to float32 rounding. ``mirror``: average the network's
        outputs over each pair and its mirror image (twice the forward passes)."""
        if engine not in ("torch", "auto"):
            raise ValueError(f"engine {engine!r}: torch or auto")
        if engine == "auto" and str(device) == "cpu":
            from rap.plan.fastcnn import load_fast_predictor

            fast = load_fast_predictor(path)
            if fast is not None:
                fast.mirror = bool(mirror)
                return cls(fast)
        from rap.model.predict import Predictor

        return cls(Predictor.load(path, device=device, mirror=mirror))

    @property
    def meta(self) -> dict:
        """What the checkpoint says about its training data (``model_familiarity``'s input)."""
        p = self.predictor
        return {"assemblies": p.assemblies, "image_stats": p.image_stats}

    def images(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The images the network takes (its checkpoint's view), uint8 [N, C, 64, 64]."""
        view = getattr(self.predictor, "view", "pair")
        if self._render is None:
            from rap.render.images import render_view

            self._render = lambda a, op, size: render_view(a, op, view, size=size)
        if not ops:
            from rap.render.images import view_channels

            return np.zeros((0, view_channels(view), IMAGE_SIZE, IMAGE_SIZE), np.uint8)
        return np.stack([np.asarray(self._render(problem.assembly, op, size=IMAGE_SIZE), np.uint8)
                         for op in ops])

    def descriptors(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray | None:
        """The geometric descriptors the network takes (``rap.model.descriptors``), float32
        [N, k], or None when it takes images only. One NDBG per assembly, kept for the few most
        recent ones."""
        names = tuple(getattr(self.predictor, "descriptors", ()) or ())
        if not names:
            return None
        from rap.model.descriptors import DescriptorContext, columns, descriptors_for

        h = problem.assembly.geometry_hash
        with self._contexts_lock:  # its caches only grow: concurrent planners may share one
            ctx = self._contexts.get(h)
            if ctx is None:
                if len(self._contexts) >= 8:
                    self._contexts.pop(next(iter(self._contexts)))
                ctx = self._contexts[h] = DescriptorContext(problem.assembly)
        return np.ascontiguousarray(descriptors_for(ctx, ops)[:, columns(names)])

    def _inputs(self, problem: PlanningProblem, ops: Sequence[Operation]):
        t = time.perf_counter()
        images = self.images(problem, ops)
        descriptors = self.descriptors(problem, ops)
        self.render_seconds += time.perf_counter() - t
        return images, descriptors

    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            return self._forward("prob_high", images, descriptors)

    def expected_score(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The model's expected success rate of each operation (binomial head; P(high) for the
        class head, the best it knows)."""
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            return self._forward("expected_score", images, descriptors)

    def prob_high_and_expected(self, problem: PlanningProblem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]:
        """``(prob_high, expected_score)`` of each operation from one rendering and one forward
        pass (a predictor without the combined call is asked twice)."""
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            if not hasattr(self.predictor, "prob_high_and_expected"):
                return (self._forward("prob_high", images, descriptors),
                        self._forward("expected_score", images, descriptors))
            return self._forward("prob_high_and_expected", images, descriptors)

    def _forward(self, what: str, images: np.ndarray, descriptors: np.ndarray | None = None):
        """The predictor's ``what`` on the images: float64 [N], or a tuple of them for a method
        that returns several (``prob_high_and_expected``)."""
        method = getattr(self.predictor, what)

        def run(lo: int, hi: int) -> tuple[np.ndarray, ...]:
            got = (method(images[lo:hi]) if descriptors is None
                   else method(images[lo:hi], descriptors[lo:hi]))
            return tuple(np.asarray(x, dtype=np.float64)
                         for x in (got if isinstance(got, tuple) else (got,)))

        busy = self.cores_busy
        if busy is None or getattr(self.predictor, "engine", None) != "numpy" or not len(images):
            parts = [run(0, len(images))]
        else:
            if self._threadpools is None:
                from threadpoolctl import ThreadpoolController

                self._threadpools = ThreadpoolController()
            parts = []
            for i in range(0, len(images), SHARE_CHUNK):
                if busy():
                    with self._threadpools.limit(limits=1, user_api="blas"):
                        parts.append(run(i, i + SHARE_CHUNK))
                else:
                    parts.append(run(i, i + SHARE_CHUNK))
        out = tuple(np.concatenate([p[j] for p in parts]) for j in range(len(parts[0])))
        return out if len(out) > 1 else out[0]


@dataclass
class ScorerStats:
    sim_requested: int = 0  # operations whose score was asked for
    sim_run: int = 0  # operations simulated fresh (cache misses)
    cache_hits: int = 0
    sim_calls: int = 0  # backend calls (batches)
    sim_seconds: float = 0.0
    cnn_batches: int = 0
    cnn_ops: int = 0
    cnn_seconds: float = 0.0

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Scorer:
    """Cached simulator scores and CNN probabilities for planners (see module doc)."""

    simulator: SimBackend
    cnn: CnnBackend | None = None
    cache: ScoreCache = field(default_factory=ScoreCache)
    budget: Budget = field(default_factory=Budget)
    stats: ScorerStats = field(default_factory=ScorerStats)
    started: float = field(default_factory=time.perf_counter)

    def fork(self, budget: Budget | None = None, cache: ScoreCache | None = None) -> "Scorer":
        """Same backends (and cache, unless given), fresh counters and clock."""
        return Scorer(self.simulator, self.cnn, self.cache if cache is None else cache,
                      self.budget if budget is None else budget)

    def _check_time(self) -> None:
        b = self.budget
        if b.max_seconds is not None and time.perf_counter() - self.started > b.max_seconds:
            raise BudgetSpent(f"time budget of {b.max_seconds:g} s spent")

    def scores(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[float]:
        """Simulator scores of ``ops`` in input order (cached; misses in one backend call)."""
        return [c.score for c in self.results(problem, ops)]

    def results(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        self._check_time()
        ops = list(ops)
        keys = [problem.key(op) for op in ops]
        found = self.cache.get_many(keys)
        missing: dict[str, Operation] = {}
        for k, op, c in zip(keys, ops, found):
            if c is None:
                missing.setdefault(k, op)
        st = self.stats
        st.sim_requested += len(ops)
        st.cache_hits += len(ops) - sum(1 for c in found if c is None)
        if missing:
            b = self.budget
            if b.max_simulations is not None and st.sim_run + len(missing) > b.max_simulations:
                raise BudgetSpent(f"simulation budget of {b.max_simulations} spent")
            t = time.perf_counter()
            fresh = self.simulator.simulate_many(problem, list(missing.values()))
            st.sim_seconds += time.perf_counter() - t
            st.sim_calls += 1
            st.sim_run += len(missing)
            if len(fresh) != len(missing):
                raise RuntimeError("simulator backend returned a wrong number of results")
            new = dict(zip(missing, fresh))
            self.cache.put_many(new.items())
            found = [c if c is not None else new[k] for k, c in zip(keys, found)]
        return found  # type: ignore[return-value]

    def prob_high(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The CNN's P(high) for each operation, one batch. Raises when no CNN is loaded."""
        return self._cnn_call("prob_high", problem, ops)

    def expected_scores(self, problem: PlanningProblem, ops: Sequence[Operation]) -> np.ndarray:
        """The CNN's expected score (success rate) for each operation, one batch."""
        return self._cnn_call("expected_score", problem, ops)

    def prob_high_and_expected(self, problem: PlanningProblem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]:
        """Both of the CNN's numbers for each operation, one batch (one rendering and forward
        pass where the backend offers ``prob_high_and_expected``, else two calls)."""
        if self.cnn is not None and not hasattr(self.cnn, "prob_high_and_expected"):
            return self.prob_high(problem, ops), self.expected_scores(problem, ops)
        return self._cnn_call("prob_high_and_expected", problem, ops)

    def _cnn_call(self, what: str, problem: PlanningProblem, ops: Sequence[Operation]):
        if self.cnn is None:
            raise RuntimeError("this scorer has no CNN (load a model for methods rap and search)")
        self._check_time()
        t = time.perf_counter()
        got = getattr(self.cnn, what)(problem, list(ops))
        self.stats.cnn_seconds += time.perf_counter() - t
        self.stats.cnn_batches += 1
        self.stats.cnn_ops += len(ops)
        out = tuple(np.asarray(x, dtype=np.float64) for x in
                    (got if isinstance(got, tuple) else (got,)))
        if any(x.shape != (len(ops),) for x in out):
            raise RuntimeError(f"CNN returned shape {[x.shape for x in out]} for {len(ops)} "
                               f"operations")
        return out if isinstance(got, tuple) else out[0]


FAMILIARITY_OPERATIONS = 64  # operations whose images ``model_familiarity`` compares


def familiarity_operations(problem: PlanningProblem,
                           limit: int = FAMILIARITY_OPERATIONS) -> list[Operation]:
    """Up to ``limit`` operations of the assembly, breadth first from the whole (its candidates,
    then those of the subassemblies they leave, each subassembly once): what ``model_familiarity``
    is calibrated on, and operations a planner looks at anyway (candidates are memoised by the
    problem). Deterministic. Cost: the candidates of the subassemblies visited, typically a few."""
    out: list[Operation] = []
    queue, seen, head = [problem.whole], set(), 0
    while head < len(queue) and len(out) < limit:
        s = queue[head]
        head += 1
        if len(s) < 2 or s in seen:
            continue
        seen.add(s)
        for op in problem.candidates(s):
            out.append(op)
            queue += [op.moving, op.fixed]
    return out[:limit]


def model_familiarity(meta: dict, geometry_hash: str, images: np.ndarray,
                      z_limit: float = 3.0, coarse_limit: float = 0.25) -> list[str]:
    """Warnings (text) when an assembly is far from what a CNN was trained on, from the
    checkpoint's metadata ``{"assemblies": [...], "image_stats": {...}}`` and the rendered images
    of the assembly's operations (``familiarity_operations``): per channel, the z-score of the
    mean foreground fraction against the training images, and the mean difference of the coarse
    8x8 foreground maps. Also says when the assembly itself was in the training data (estimates
    are optimistic). The limits sit above what the shipped model's own training assemblies give
    on ``FAMILIARITY_OPERATIONS`` operations each (at most z 1.9 and coarse 0.21 over its 334;
    tested). On the few candidates of the whole assembly alone the statistic is too noisy: 11 of
    them passed the limits there, a reference assembly among them."""
    notes = []
    trained = meta.get("assemblies") or []
    for a in trained:
        h = a.get("geometry_hash")
        if h == geometry_hash or (isinstance(h, list) and geometry_hash in h):
            notes.append(f"this assembly ({a.get('name')}) was in the model's training data: its "
                         f"predictions are not a test of generalisation")
    ref = meta.get("image_stats") or {}
    if len(images) and ref.get("foreground_mean") and ref.get("coarse_foreground") is not None:
        new = foreground_stats(np.asarray(images, dtype=np.uint8))
        z = [(m - rm) / rs if rs > 0 else 0.0 for m, rm, rs in
             zip(new["foreground_mean"], ref["foreground_mean"], ref["foreground_std"])]
        coarse = float(np.abs(np.asarray(new["coarse_foreground"])
                              - np.asarray(ref["coarse_foreground"])).mean())
        if max(abs(v) for v in z) > z_limit or coarse > coarse_limit:
            notes.append(f"this assembly looks unlike the model's training data (foreground "
                         f"z-scores {', '.join(f'{v:+.1f}' for v in z)}; coarse layout difference "
                         f"{coarse:.2f}; trained on {_trained_on(trained)}): expect "
                         f"more simulator fallbacks or less robust choices")
    return notes


def _trained_on(trained: list[dict]) -> str:
    names = [a.get("name", "?") for a in trained]
    if not names:
        return "unknown assemblies"
    if len(names) <= 8:
        return ", ".join(names)
    fams = sorted({re.sub(r"-s\d+$", "", n) if re.search(r"-s\d+$", n) else "reference"
                   for n in names})
    return f"{len(names)} assemblies of {len(fams)} kinds: {', '.join(fams)}"


def foreground_stats(images: np.ndarray) -> dict:
    """Of uint8 images [n, c, h, w]: per channel the mean foreground fraction (pixels > 0) and the
    coarse 8x8 mean foreground map; the definitions of ``rap.model.data.image_stats``, which the
    checkpoint stores for its training images (computed here without importing pyarrow)."""
    k, c, hgt, wid = images.shape
    fg = images > 0
    return {"foreground_mean": fg.reshape(k, c, -1).mean(axis=2).mean(axis=0).tolist(),
            "coarse_foreground": fg.reshape(k, c, 8, hgt // 8, 8, wid // 8).mean(axis=(3, 5))
                                   .mean(axis=0).round(5).tolist()}
