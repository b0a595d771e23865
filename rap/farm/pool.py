"""``SimPool``: an elastic pool of simulation actors shared by the labelling farm and the planner.

Usage (Ray already initialised, e.g. inside ``rap.farm.runtime.connect()``)::

    pool = SimPool(workers=4)                          # up to 4 actors of one CPU, spread over nodes
    pool.ready(timeout_s=120, at_least=1)              # wait for one actor, not for all of them
    results = pool.score(assembly, ops, params, root_seed)       # list[Scored], input order
    for batch in pool.stream(pool.jobs(assembly, ops, params, root_seed)):   # completion order
        ...                                            # batch.table: the rows
    pool.shutdown()

Design (Ray's core patterns):

* every assembly is ``ray.put`` once per pool (cached by geometry hash) and fetched once per worker;
* operations are batched per task; with ``batch_size=None`` the batch adapts so that a task runs
  about ``target_task_s`` (well over Ray's per-task overhead), or ``started actors / TASK_RATE``
  seconds when that is longer (the driver then sends at most about ``TASK_RATE`` tasks a second,
  a few ms of its CPU each, however large the cluster; up to ``max_batch`` operations: 128, what
  that rule gives at about 1,400 actors of the real simulator), and the last wave splits evenly;
* at most ``per_worker_in_flight`` tasks per started actor are in flight (``ray.wait``); jobs are
  pulled from the input iterator only when there is room, so the driver's memory does not grow
  with the input;
* a label depends only on (root seed, content key): never on the worker count, the node, or
  completion order;
* one pool serves concurrent callers (threads of the planning service): each ``stream``/``score``
  call waits on its own tasks, and the shared bookkeeping (actors, loads, assembly references,
  statistics) is updated under one short lock, never held while waiting on Ray.

The actors themselves, their growth with the cluster, idle release and lost nodes:
``rap.farm.workers.WorkerSet``, the base class.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Iterable, Iterator, Sequence

import ray
from ray.exceptions import RayError, RayTaskError

from rap.assembly import Assembly
from rap.enumerate import label_key, label_seed
from rap.operation import Operation

from rap.farm.actors import Backend, BatchResult, SimTask
from rap.farm.faults import (BACKOFF_S, MAX_ATTEMPTS, PROGRESS_TIMEOUT_S, Tries, backoff_s,
                             cause_line, is_lost)
from rap.farm.workers import IDLE_TIMEOUT_S, WAKE_S, FarmError, WorkerSet
from rap.labelling.rows import params_json, rows_table
from rap.labelling.selection import Job

__all__ = ["SimPool", "Job", "Scored", "FarmError", "params_json", "IDLE_TIMEOUT_S", "TASK_RATE"]

TASK_RATE = 100.0  # tasks a second the adaptive batch aims at, at most, on a large pool


@dataclass(frozen=True)
class Scored:
    """The label of one operation as the planner sees it (``image`` only when asked for)."""

    operation: Operation
    key: str
    seed: int
    successes: int
    trials: int
    score: float
    seconds: float
    node: str
    image: bytes | None = None



class SimPool(WorkerSet):
    """An elastic set of ``SimWorker`` actors with batching, bounded in-flight tasks and retries.

    Parameters: ``workers`` (the most actors to ask for; None: one per CPU of the cluster, growing
    with it), ``backend`` (simulator/renderer import paths), ``batch_size`` (None: adaptive),
    ``target_task_s``, ``max_batch``, ``per_worker_in_flight``, ``max_attempts`` (submissions of
    a batch whose simulation raises), ``progress_timeout_s`` (a batch lost with its worker is
    resubmitted, after ``backoff_s`` doubling, until no batch has completed for that long; None:
    for ever; ``rap.farm.faults``), ``max_restarts``/``max_task_retries`` (Ray's own actor fault
    tolerance), ``cpus_per_worker``, ``idle_timeout_s`` (None: never release actors),
    ``stall_timeout_s`` (None: wait for ever; else ``FarmError`` when work has been queued that
    long with no started actor to take it).
    """

    def __init__(self, workers: int | None = None, *, backend: Backend = Backend(),
                 batch_size: int | None = None, target_task_s: float = 1.0, max_batch: int = 128,
                 per_worker_in_flight: int = 2, max_attempts: int = MAX_ATTEMPTS,
                 progress_timeout_s: float | None = PROGRESS_TIMEOUT_S,
                 backoff_s: float = BACKOFF_S, max_restarts: int = 8,
                 max_task_retries: int = 0, cpus_per_worker: float = 1.0,
                 idle_timeout_s: float | None = None, stall_timeout_s: float | None = None):
        if batch_size is not None and batch_size < 1:
            raise ValueError("batch_size must be >= 1")
        self.batch_size = batch_size
        self.target_task_s = float(target_task_s)
        self.max_batch = int(max_batch)
        self.per_worker_in_flight = max(1, int(per_worker_in_flight))
        self.max_attempts = max(1, int(max_attempts))
        self.progress_timeout_s = progress_timeout_s
        self.backoff_s = float(backoff_s)
        self._next_task = 0
        self._per_op_s: float | None = None  # moving average of task seconds per operation
        super().__init__(workers, backend=backend, max_restarts=max_restarts,
                         max_task_retries=max_task_retries, cpus_per_worker=cpus_per_worker,
                         idle_timeout_s=idle_timeout_s, stall_timeout_s=stall_timeout_s)

    # -- inputs -------------------------------------------------------------------------------------
    def put_assembly(self, assembly: Assembly):
        """The object-store reference of ``assembly`` (``ray.put`` once per geometry hash)."""
        gh = assembly.geometry_hash
        with self._lock:
            ref = self._refs.get(gh)
            if ref is None:
                ref = self._refs[gh] = ray.put(assembly)
        return ref

    @staticmethod
    def jobs(assembly: Assembly, operations: Iterable[Operation], params: Any,
             root_seed: int) -> Iterator[Job]:
        """Jobs (key + seed) for ``operations`` of ``assembly`` under ``params`` and ``root_seed``."""
        gh, fp = assembly.geometry_hash, params.fingerprint()
        for op in operations:
            yield Job(assembly, op, label_key(op, gh, fp, root_seed), label_seed(op, gh, fp, root_seed))

    # -- running ------------------------------------------------------------------------------------
    def _batch_len(self, remaining: int | None) -> int:
        if self.batch_size is not None:
            b = self.batch_size
        elif self._per_op_s is None:
            b = 2
        else:  # a task of target_task_s, longer on a large pool: at most ~TASK_RATE tasks/s
            task_s = max(self.target_task_s, self._started / TASK_RATE)
            b = int(round(task_s / max(self._per_op_s, 1e-6)))
        b = max(1, min(b, self.max_batch))
        if remaining is not None:
            b = min(b, max(1, math.ceil(remaining / max(1, self._started))))
        return b

    def stream(self, jobs: Iterable[Job], params: Any, *, images: bool = True,
               total: int | None = None, errors: str = "raise") -> Iterator[BatchResult]:
        """Label ``jobs`` and yield each completed batch (completion order).

        ``total`` (the number of jobs, when known) balances the last wave. Consecutive jobs of the
        same assembly share a task. A batch lost with its worker is resubmitted while the pool
        makes progress; one whose simulation fails ``max_attempts`` times, or that is lost after
        no batch has completed for ``progress_timeout_s`` (``rap.farm.faults``), raises
        ``FarmError`` (``errors="raise"``) or is yielded as a ``BatchResult`` with no rows and
        ``error`` set, the stream going on (``errors="collect"``). Closing the generator cancels
        what is in flight.
        """
        return self._drive(_JobTasks(self, jobs, params, images, total), errors)

    def run_tasks(self, tasks: Iterable[Any], *, errors: str = "raise") -> Iterator[BatchResult]:
        """Run ready-made tasks (each with ``task_id``, ``assembly_name`` and ``keys``; what
        ``SimWorker.run`` takes, e.g. ``rap.farm.actors.RolloutTask``) with ``stream``'s
        retries and in-flight limit; yields each result in completion order."""
        return self._drive(_ListTasks(tasks), errors)

    def next_task_id(self) -> int:
        with self._lock:
            self._next_task += 1
            return self._next_task

    def _drive(self, source, errors: str) -> Iterator[BatchResult]:
        """``stream``'s loop over the tasks of ``source`` (``more``: tasks may still come;
        ``next()``: the next task, or None)."""
        if errors not in ("raise", "collect"):
            raise ValueError("errors must be 'raise' or 'collect'")
        if self._stop.is_set():
            raise RuntimeError("SimPool has been shut down")
        in_flight: dict[Any, tuple[Tries, int]] = {}  # ref -> (the batch, its actor)
        retry: list[Tries] = []  # batches to send again (each when its backoff is over)
        idle_since: float | None = None  # since when work has waited with no started actor
        demand = [False]  # whether this call counts among the pool's callers with work queued
        began = time.monotonic()

        def due() -> Tries | None:
            now = time.monotonic()
            for i, t in enumerate(retry):
                if t.not_before <= now:
                    return retry.pop(i)
            return None

        try:
            while True:
                self._poll()
                fresh = source.more
                self._want(fresh or bool(retry), demand)
                if fresh or retry:
                    self._demand(fresh, bool(retry))
                cap = self._started * self.per_worker_in_flight
                while len(in_flight) < cap:
                    t = due()
                    if t is None:
                        task = source.next() if source.more else None
                        if task is None:
                            break
                        t = Tries(task)
                    sent = self._submit(t.task, t.avoid)
                    if sent is None:  # the actors went away meanwhile
                        retry.insert(0, t)
                        break
                    in_flight[sent[0]] = (t, sent[1])
                if not in_flight:
                    if not retry and not source.more:
                        return
                    now = time.monotonic()
                    idle_since = None if self._started else (idle_since or now)
                    if (idle_since is not None and self.stall_timeout_s is not None
                            and now - idle_since > self.stall_timeout_s):
                        raise FarmError(f"no simulation worker has been running for "
                                        f"{self.stall_timeout_s:.0f} s (lost nodes, or no free "
                                        f"CPUs on the cluster)")
                    wait, t0 = self._wake(retry), time.monotonic()
                    if not self._poll(wait):  # nothing started: wait out the backoff's rest
                        time.sleep(max(0.0, wait - (time.monotonic() - t0)))
                    continue
                idle_since = None
                probes = list(self._probes())
                done, _ = ray.wait(list(in_flight) + probes, num_returns=1,
                                   timeout=self._wake(retry))
                for ref in done:
                    if ref not in in_flight:  # an actor answered its probe: _poll takes it in
                        continue
                    t, k = in_flight.pop(ref)
                    self._release(k)
                    try:
                        res: BatchResult = self._fetch(ref)
                    except RayError as exc:
                        msg = self._again(t, k, exc, retry, began)
                        if msg is None:
                            continue
                        if errors == "raise":
                            raise FarmError(msg) from exc
                        yield self._failed(t.task, msg)
                        continue
                    res.attempts = t.submissions
                    self._account(res)
                    yield res
        finally:
            self._want(False, demand)
            for ref in in_flight:
                try:
                    ray.cancel(ref)
                except Exception:
                    pass
            for _, k in in_flight.values():
                self._release(k)

    def _again(self, t: Tries, k: int, exc: BaseException, retry: list[Tries],
               began: float) -> str | None:
        """Batch ``t`` came back from actor ``k`` with ``exc``: queue it again (None) or say why
        not (one line). Lost and failing batches: ``rap.farm.faults``."""
        now = time.monotonic()
        name = t.task.assembly_name
        if is_lost(exc):
            self._lost(k)
            t.losses += 1
            with self._lock:
                self.stats["lost"] += 1
                quiet = now - max(self._progress_at, began)
            if self.progress_timeout_s is not None and quiet >= self.progress_timeout_s:
                return (f"a batch of {name} was lost {t.losses} times ({type(exc).__name__}) and "
                        f"no batch has completed for {self.progress_timeout_s:g} s")
            t.not_before = now + backoff_s(t.losses, self.backoff_s)
        elif isinstance(exc, RayTaskError):  # the simulator raised
            t.failures += 1
            if t.failures >= self.max_attempts:
                return f"simulation of a batch of {name} failed: {cause_line(exc)}"
            with self._lock:
                self.stats["retried"] += 1
        else:
            raise exc
        with self._lock:
            self.stats["resubmitted"] += 1
            self.stats["redone_ops"] += len(t.task.keys)
        t.avoid = k
        retry.append(t)
        return None

    @staticmethod
    def _wake(retry: list[Tries]) -> float:
        """How long the stream may wait: ``WAKE_S``, less when a backoff ends sooner."""
        now = time.monotonic()
        ends = [t.not_before - now for t in retry if t.not_before > now]
        return min([WAKE_S, *ends])

    @staticmethod
    def _failed(task: SimTask, msg: str) -> BatchResult:
        return BatchResult(task_id=task.task_id, table=rows_table([]), node="", pid=0,
                           assembly=task.assembly_name, error=msg)

    def _account(self, res: BatchResult) -> None:
        if "chunks" in res.extra:  # rollouts: not labels, no batch-size statistics
            return
        n = max(1, res.num_rows)
        per = res.task_s / n
        with self._lock:
            s = self.stats
            s["ops"] += res.num_rows
            s["sim_s"] += res.sim_s
            s["render_s"] += res.render_s
            s["task_s"] += res.task_s
            self._progress_at = time.monotonic()
            self._per_op_s = per if self._per_op_s is None else 0.7 * self._per_op_s + 0.3 * per

    def score(self, assembly: Assembly, operations: Sequence[Operation], params: Any,
              root_seed: int, *, images: bool = False) -> list[Scored]:
        """Label ``operations`` of ``assembly`` in parallel; results in input order.

        Same operation, params and root seed -> same result, whichever worker runs it.
        """
        ops = list(operations)
        jobs = list(self.jobs(assembly, ops, params, root_seed))
        slots: dict[str, list[int]] = {}
        for idx, j in enumerate(jobs):
            slots.setdefault(j.key, []).append(idx)
        out: list[Scored | None] = [None] * len(ops)
        unique = [jobs[idxs[0]] for idxs in slots.values()]
        for res in self.stream(unique, params, images=images, total=len(unique)):
            for r in res.rows:
                s = Scored(operation=ops[slots[r["key"]][0]], key=r["key"], seed=r["seed"],
                           successes=r["successes"], trials=r["trials"], score=r["score"],
                           seconds=r.get("seconds", 0.0), node=r["node"], image=r["image"])
                for idx in slots[r["key"]]:
                    out[idx] = s
        return out  # type: ignore[return-value]



class _JobTasks:
    """``SimTask`` s from a stream of jobs: consecutive jobs of one assembly batched (the batch's
    length from ``SimPool._batch_len``)."""

    def __init__(self, pool: SimPool, jobs: Iterable[Job], params: Any, images: bool,
                 total: int | None):
        self.pool, self.params, self.images, self.total = pool, params, images, total
        self.pjson = params_json(params)
        self.it = iter(jobs)
        self.head: list[Job] = []  # one look-ahead job that belongs to the next batch
        self.exhausted = False
        self.submitted = 0

    @property
    def more(self) -> bool:
        return bool(self.head) or not self.exhausted

    def next(self) -> SimTask | None:
        remaining = None if self.total is None else max(1, self.total - self.submitted)
        want = self.pool._batch_len(remaining)
        batch: list[Job] = self.head[:]
        self.head.clear()
        while len(batch) < want and not self.exhausted:
            try:
                j = next(self.it)
            except StopIteration:
                self.exhausted = True
                break
            if batch and j.assembly.geometry_hash != batch[0].assembly.geometry_hash:
                self.head.append(j)
                break
            batch.append(j)
        if not batch:
            return None
        self.submitted += len(batch)
        a = batch[0].assembly
        return SimTask(task_id=self.pool.next_task_id(), assembly_name=a.name,
                       geometry_hash=a.geometry_hash, assembly_ref=[self.pool.put_assembly(a)],
                       operations=tuple(j.operation for j in batch),
                       keys=tuple(j.key for j in batch), seeds=tuple(j.seed for j in batch),
                       params=self.params, params_json=self.pjson, images=self.images)


class _ListTasks:
    """Ready-made tasks, in order."""

    def __init__(self, tasks: Iterable[Any]):
        self._left = list(tasks)
        self._left.reverse()

    @property
    def more(self) -> bool:
        return bool(self._left)

    def next(self) -> Any:
        return self._left.pop() if self._left else None
