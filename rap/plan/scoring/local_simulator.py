"""Simulator scores on this machine: ``LocalSimulator``, a ``SimBackend`` of ``rap.plan.scoring.scorer``.

``LocalSimulator`` runs ``rap.sim.simulator.simulate`` with the per-operation seed
``problem.seed(op)`` (the labelling farm's seed, so the scores equal the dataset's labels for the
same parameters and root seed): in this process, or, with ``processes > 1``, a batch of at least
``min_batch`` (``MIN_PROCESS_BATCH``, 8) operations spread over that many forked worker processes,
started at the first such batch (well under a second, against 10-30 s for a local Ray) and kept
until ``close()``. With ``prestart=True`` the workers are forked at once and load the compiled
simulator while the caller plans (a one-off ``rap-farm plan``: the ~0.75 s of loading and the
~0.35 s that an interpreter which loaded numba takes to exit stay off the planner's core); every
batch then goes to them.

The workers are a ``concurrent.futures.ProcessPoolExecutor`` over a fork context that keeps the
processes it starts (``LocalSimulator.workers``), so that ``close()`` can stop workers still
loading the simulator with public calls only (``Process.kill``, then ``shutdown(wait=True)``;
``kill_workers`` on Python 3.14 and later), also when a signal interrupts the close; Ctrl-C and
SIGTERM wait until the forks are done; a worker whose parent has gone without closing it
(SIGKILL) ends by itself within a second.

``simulate_chunks(problem, chunks)``: the chunks of sequential tests (``research.variants.sequential``),
each ``(op, index, trials)`` one run of ``trials`` trials from ``chunk_seed(problem.seed(op),
index)``, in the same way (never cached: not labels).

``run_rollouts(assembly, plan, root_seed, work)``: chunks of whole-plan rollouts
(``rap.execution``) on the same workers.

Same seeds, same scores in every configuration. No ray, no torch.

Example::

    sim = LocalSimulator(processes=2)
    try:
        scores = sim.simulate_many(problem, ops)   # list[CachedScore], in input order
    finally:
        sim.close()
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Callable, Sequence

import numpy as np

from rap.operation import Operation
from rap.plan.scoring.cache import CachedScore
from rap.plan.problem import PlanningProblem

__all__ = ["LocalSimulator", "MIN_PROCESS_BATCH", "WARM_NICE"]

#: the smallest batch that ``LocalSimulator`` spreads over worker processes: each new worker loads
#: the compiled simulator (~0.3 s) and competes with the planner for the cores, so a handful of
#: operations (a greedy plan's evaluation: one per step) is simulated faster in the process itself
MIN_PROCESS_BATCH = 8
#: niceness of prestarted workers: while they load the simulator the parent plans on the same
#: cores and comes first (a warm score cache needs no simulation at all; docs/RESULTS.md,
#: "Planning latency"); once the parent waits for their results they have the machine
WARM_NICE = 10


def _simulate_one(simulate: Callable | None, assembly, op, params, seed: int) -> CachedScore:
    if simulate is None:
        from rap.sim.simulator import simulate
    res = simulate(assembly, op, params, np.random.default_rng(seed))
    return CachedScore(float(res.score), int(res.successes), int(res.trials))


def _simulate_task(args) -> CachedScore:  # runs in a worker process
    return _simulate_one(None, *args)


def _rollout_task(args):  # runs in a worker process
    from rap.execution.rollout import run_chunk

    return run_chunk(*args)


def _tolerance_task(args) -> float:  # runs in a worker process
    from rap.execution.tolerance import tolerance

    return tolerance(*args)


def _perturbed_task(args) -> int:  # runs in a worker process
    from rap.execution.perturbed import perturbed_successes

    return perturbed_successes(*args)


def _exit_with(parent: int) -> None:  # a worker's daemon thread
    """End this worker once process ``parent``, which forked it, has gone without stopping it
    (SIGKILL, or a signal between a fork and the pool's record of it): an orphan would otherwise
    wait for work for good."""
    import time

    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(0)


def _worker_init(warmed=None, parent: int | None = None) -> None:
    """Worker processes leave Ctrl-C to the parent, which stops them (no traceback per worker),
    and end quietly on SIGTERM (the parent's ``close``, or a signal to the whole process group):
    the handler forked from the CLI (SIGTERM as Ctrl-C) is not theirs; they end when ``parent``
    does; with a shared counter ``warmed``, load the compiled simulator now rather than at the
    first operation (at a lower priority), then count this worker as warm."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), daemon=True).start()
    if warmed is not None:
        os.nice(WARM_NICE)
        from rap.sim.simulator import warm_up

        warm_up()
        with warmed.get_lock():
            warmed.value += 1


def _noop() -> None:  # submitted once to make a fork pool start its workers
    return None


@contextlib.contextmanager
def _signals_held():
    """Ctrl-C and SIGTERM held back while the pool forks (in the main thread, where Python runs
    signal handlers), then raised again: a handler that raises (the CLI's KeyboardInterrupt) would
    otherwise run inside an at-fork hook (logging's), where the exception is printed and dropped,
    and the command would go on, deaf to the signal (its handler then ignores a second one)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    held = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    held = {s: h for s, h in held.items() if h is not None}  # None: not set from Python
    for s in held:
        signal.signal(s, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        for s, handler in held.items():
            signal.signal(s, handler)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


def _stop_workers(ex, workers: list) -> None:
    """Kill the processes ``workers`` of executor ``ex`` and shut it down (again: harmless)."""
    kill_workers = getattr(ex, "kill_workers", None)  # Python >= 3.14
    if kill_workers is not None:
        kill_workers()
        return
    for proc in workers:
        # SIGKILL, not SIGTERM: a worker forked a moment ago may not have run its initializer
        # yet and still carry the parent's SIGTERM handler; seen once to leave a worker alive
        # and close() waiting on it for good (a test run). A process made but not started (an
        # interrupt between the two) has no pid and nothing to stop.
        if proc.pid is not None:
            proc.kill()
    # The executor's manager thread sees them gone and joins them (the same process objects):
    # waiting for it, rather than joining them here as well, leaves none that reads as alive
    # (two threads reaping one child race: waitpid's ECHILD).
    ex.shutdown(wait=True, cancel_futures=True)


def _fork_context(started: list):
    """The fork context of ``multiprocessing``, appending every process it makes to ``started``
    (the executor makes its workers with ``mp_context.Process``)."""
    import multiprocessing

    fork = type(multiprocessing.get_context("fork"))

    class Recording(fork):
        def Process(self, *args, **kwargs):
            proc = fork.Process(*args, **kwargs)
            started.append(proc)
            return proc

    return Recording()


class LocalSimulator:
    """``rap.sim.simulator.simulate`` on this machine (``simulate`` replaceable): sequentially in
    this process, or over ``processes`` forked workers for batches of ``min_batch`` or more
    operations (Linux; the real simulator only); with ``prestart``, over ``processes`` workers (one
    or more) forked now, which load the simulator at once and take every batch. Same seeds, same
    scores either way. A pool that breaks (a worker killed) is dropped and the batch simulated
    here. ``workers``: the processes of the pool now running (empty when none)."""

    def __init__(self, simulate: Callable | None = None, *, processes: int = 1,
                 min_batch: int = MIN_PROCESS_BATCH, prestart: bool = False):
        self._simulate = simulate
        self.processes = max(1, int(processes))
        self.min_batch = max(1, int(min_batch))
        self._executor = None
        self.workers: list = []  # the worker processes of ``_executor`` (multiprocessing.Process)
        self._lock = threading.Lock()
        self._warmed = None  # shared count of prestarted workers that have loaded the simulator
        self.prestarted = bool(prestart) and self._can_fork()
        if self.prestarted:
            try:
                self._pool()  # forks the workers now
            except BaseException:  # interrupted while forking (SIGTERM as Ctrl-C): none is left
                self.close()
                raise

    def loading(self) -> bool:
        """True while prestarted workers are still loading the simulator (the caller then leaves
        them a core: see ``OperationPredictor.cores_busy``)."""
        warmed = self._warmed
        return self.prestarted and warmed is not None and warmed.value < self.processes

    def _can_fork(self) -> bool:
        return self._simulate is None and sys.platform.startswith("linux")

    def _pool(self):
        if not self._can_fork() or (self.processes < 2 and not self.prestarted):
            return None
        with self._lock:
            if self._executor is None:
                from concurrent.futures import ProcessPoolExecutor

                self.workers = []
                ctx = _fork_context(self.workers)
                if self.prestarted:
                    self._warmed = ctx.Value("i", 0)
                else:
                    from rap.sim import simulator  # noqa: F401  (imported once, before the fork)
                self._executor = ProcessPoolExecutor(self.processes, mp_context=ctx,
                                                     initializer=_worker_init,
                                                     initargs=(self._warmed, os.getpid()))
                with _signals_held():  # a fork pool starts all its workers at the first submit
                    self._executor.submit(_noop)
            return self._executor

    def simulate_many(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        return self._run([(problem.assembly, op, problem.params, problem.seed(op)) for op in ops])

    def run_rollouts(self, assembly, plan, root_seed: int, work: Sequence[tuple[int, int]]):
        """Chunks of whole-plan rollouts (``rap.execution.sequence.RolloutRunner``), over the
        worker processes when there are two chunks or more; results in the order of ``work``,
        the same in every configuration (each chunk depends on its indices only)."""
        from rap.execution.rollout import run_chunk

        jobs = [(assembly, plan, root_seed, first, count) for first, count in work]
        return self._mapped(_rollout_task, jobs, len(jobs) >= 2, run_chunk)

    def run_tolerances(self, jobs: Sequence[tuple]) -> list[float]:
        """``rap.execution.tolerance.tolerance(*job)`` for each job, over the worker processes when
        there are two or more (``ToleranceRunner``); results in the order of ``jobs``."""
        from rap.execution.tolerance import tolerance

        return self._mapped(_tolerance_task, list(jobs), len(jobs) >= 2, tolerance)

    def run_perturbed(self, jobs: Sequence[tuple]) -> list[int]:
        """``rap.execution.perturbed.perturbed_successes(*job)`` for each job, over the worker
        processes when there are two or more (``PerturbedRunner``); results in order."""
        from rap.execution.perturbed import perturbed_successes

        return self._mapped(_perturbed_task, list(jobs), len(jobs) >= 2, perturbed_successes)

    def _run(self, jobs: list) -> list[CachedScore]:
        return self._mapped(_simulate_task, jobs, len(jobs) >= self.min_batch,
                            lambda *j: _simulate_one(self._simulate, *j))

    def _mapped(self, task: Callable, jobs: list, enough: bool, here: Callable) -> list:
        """``task`` over ``jobs`` on the worker processes when there are ``enough`` of them (or
        the workers were prestarted), else ``here(*job)`` in this process; results in the order
        of ``jobs``. A pool that breaks (a worker killed) is dropped and the jobs run here."""
        pool = self._pool() if self.prestarted or enough else None
        if pool is not None:
            from concurrent.futures.process import BrokenProcessPool

            try:
                return list(pool.map(task, jobs))
            except BrokenProcessPool:
                self.close()
                self.prestarted, self.processes = False, 1
        return [here(*j) for j in jobs]

    def close(self) -> None:
        """Stop the worker processes (if any were started). Workers still loading the simulator
        are killed rather than waited for: they hold nothing that must be kept. A close
        interrupted halfway (Ctrl-C, or SIGTERM as Ctrl-C) stops them all before the interrupt
        goes on."""
        with self._lock:
            ex, self._executor = self._executor, None
            workers, self.workers = self.workers, []
        if ex is None:
            return
        try:
            _stop_workers(ex, workers)
        except BaseException:
            _stop_workers(ex, workers)
            raise


