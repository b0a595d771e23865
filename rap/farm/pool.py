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
  about ``target_task_s`` (well over Ray's per-task overhead) and the last wave splits evenly;
* at most ``per_worker_in_flight`` tasks per started actor are in flight (``ray.wait``); jobs are
  pulled from the input iterator only when there is room, so the driver's memory does not grow
  with the input;
* a label depends only on (root seed, content key): never on the worker count, the node, or
  completion order;
* one pool serves concurrent callers (threads of the planning service): each ``stream``/``score``
  call waits on its own tasks, and the shared bookkeeping (actors, loads, assembly references,
  statistics) is updated under one short lock, never held while waiting on Ray.

Elasticity (the pool on an autoscaling cluster):

* **Start on what exists, ask for the rest.** The pool creates its actors at once and never waits
  for them: an actor that cannot be placed yet stays *pending*, and a pending actor is a resource
  demand that Ray's autoscaler answers with a node. Work goes only to actors that have answered a
  probe (``SimWorker.info``); ``ready(at_least=1)`` returns as soon as one has. With
  ``workers=N`` the pool asks for N actors (the maximum); with ``workers=None`` it takes one actor
  per CPU of the cluster and adds one for every CPU that joins or frees up later, without asking
  for nodes (so two elastic pools on one cluster do not ask the autoscaler for each other's CPUs).
  Pending actors rather than ``ray.autoscaler.sdk.request_resources``: a resource request stays
  until it is replaced and keeps its nodes up while nothing runs on them, whereas an actor's
  demand goes with the actor, when the pool releases it or its process ends.
* **Use nodes as they join.** A pending actor that starts (its node joined) gets work at once: the
  pool waits on the actors' probes together with its tasks.
* **Release what is idle.** With ``idle_timeout_s``, an actor that has had nothing to do for that
  long while the pool had no queued work is killed (a pending one too: its demand is withdrawn), so
  the autoscaler can remove its node after its own ``idle_timeout_minutes``; the pool grows again
  when work comes. Without it (the planning service) the actors stay warm until ``shutdown``.
* **Survive lost nodes** (spot preemption). ``max_task_retries=0``: a task whose actor or node
  dies fails at once, and the pool resubmits its batch to another started actor (at most
  ``max_attempts`` submissions) instead of letting Ray hold it until the actor has restarted on a
  node that may take minutes to come; the actor itself restarts (``max_restarts``) and rejoins when
  it answers a probe again, and one dead for good is replaced while fresh work is queued. A result
  never arrives twice for one submission, and the driver de-duplicates by key, so a run loses and
  duplicates no row.

Why not Ray Data's autoscaling actor pool (``map_batches`` with ``ActorPoolStrategy(min_size,
max_size)``), which does the same growing and shrinking: the planning service needs a warm pool
that answers many small concurrent batches in input order within milliseconds, and a Ray Data
execution starts its own executor and actor pool per dataset (measured on a local Ray of 2 CPUs,
8 operations of 100 ms on 2 workers, ideal 0.40 s: Ray Data's pool 10.4 s the first time and
4.9 s per batch after, a warm ``SimPool`` 0.52 s; ``python benchmarks/farm_scale.py
--max-workers 2 --ops-per-worker 10 --ray-data``); the driver needs resume by key,
per-assembly failure isolation and bounded memory on lazily selected operations, which ``stream``
has. One pool for both keeps one code path for labels, so the elastic behaviour is built here.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator, Sequence

import ray
from ray.exceptions import (ActorDiedError, ActorUnavailableError, NodeDiedError, ObjectLostError,
                            OwnerDiedError, RayActorError, RayTaskError, WorkerCrashedError)

from rap.assembly import Assembly
from rap.enumerate import label_key, label_seed
from rap.errors import WorkFailedError
from rap.operation import Operation

from rap.farm.actors import Backend, BatchResult, SimTask, SimWorker
from rap.labelling.rows import params_json, rows_table
from rap.labelling.selection import Job
from rap.farm.runtime import cluster_cpus

__all__ = ["SimPool", "Job", "Scored", "FarmError", "params_json", "IDLE_TIMEOUT_S"]

_REMOTE_WORKER = ray.remote(SimWorker)

_LOST = (RayActorError, ActorDiedError, ActorUnavailableError, WorkerCrashedError, NodeDiedError,
         ObjectLostError, OwnerDiedError)

#: what ``rap-farm label`` gives ``idle_timeout_s``: an actor without work for a minute (the run's
#: tail, a driver busy selecting) is released; the autoscaler then waits its own idle timeout
IDLE_TIMEOUT_S = 60.0
_WAKE_S = 1.0  # the stream's longest wait before it looks at probes, growth and stalls again
_FOLLOW_EVERY_S = 2.0  # workers=None: how often the cluster's free CPUs are read
_PROBE_FAILURES = 50  # failed probes (restarting, unreachable) before an actor is given up


class FarmError(WorkFailedError):
    """A batch that could not be labelled, or no worker to label it (exit status 3)."""


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


@dataclass
class _Actor:
    """One actor and the pool's view of it. ``probe``: the pending ``info()`` call while the actor
    has not (re)started; ``None`` once it answers (or, after unpickling, until one is sent)."""

    handle: Any
    probe: Any = None
    started: bool = False
    load: int = 0
    idle_since: float = field(default_factory=time.monotonic)
    info: dict = field(default_factory=dict)
    failures: int = 0


class SimPool:
    """An elastic set of ``SimWorker`` actors with batching, bounded in-flight tasks and retries.

    Parameters: ``workers`` (the most actors to ask for; None: one per CPU of the cluster, growing
    with it), ``backend`` (simulator/renderer import paths), ``batch_size`` (None: adaptive),
    ``target_task_s``, ``max_batch``, ``per_worker_in_flight``, ``max_attempts`` (submissions of
    one batch by the pool), ``max_restarts``/``max_task_retries`` (Ray's own actor fault
    tolerance), ``cpus_per_worker``, ``idle_timeout_s`` (None: never release actors),
    ``stall_timeout_s`` (None: wait for ever; else ``FarmError`` when work has been queued that
    long with no started actor to take it).
    """

    def __init__(self, workers: int | None = None, *, backend: Backend = Backend(),
                 batch_size: int | None = None, target_task_s: float = 1.0, max_batch: int = 64,
                 per_worker_in_flight: int = 2, max_attempts: int = 4, max_restarts: int = 8,
                 max_task_retries: int = 0, cpus_per_worker: float = 1.0,
                 idle_timeout_s: float | None = None, stall_timeout_s: float | None = None):
        if not ray.is_initialized():
            raise RuntimeError("SimPool needs Ray: call inside rap.farm.runtime.connect() or ray.init()")
        if workers is not None and int(workers) < 1:
            raise ValueError("workers must be >= 1")
        if batch_size is not None and batch_size < 1:
            raise ValueError("batch_size must be >= 1")
        self.backend = backend
        self.max_workers = int(workers) if workers else None
        self.batch_size = batch_size
        self.target_task_s = float(target_task_s)
        self.max_batch = int(max_batch)
        self.per_worker_in_flight = max(1, int(per_worker_in_flight))
        self.max_attempts = max(1, int(max_attempts))
        self.cpus_per_worker = float(cpus_per_worker)
        self.idle_timeout_s = idle_timeout_s
        self.stall_timeout_s = stall_timeout_s
        self._actor_options = dict(num_cpus=cpus_per_worker, max_restarts=max_restarts,
                                   max_task_retries=max_task_retries, scheduling_strategy="SPREAD")
        self._lock = threading.Lock()  # bookkeeping only (see module doc)
        self._actors: dict[int, _Actor] = {}
        self._next_actor = 0
        self._started = 0
        self._refs: dict[str, Any] = {}  # geometry hash -> ObjectRef of the Assembly
        self._next_task = 0
        self._per_op_s: float | None = None  # moving average of task seconds per operation
        self._last_demand = time.monotonic()  # when the last caller stopped having work queued
        self._demanding = 0  # callers (streams, ready) that have work queued now
        self._followed = 0.0  # workers=None: when the free CPUs were last read
        self._last_death = ""  # why the last actor died for good (for the error of a dead pool)
        self.stats = {"tasks": 0, "resubmitted": 0, "replaced": 0, "ops": 0, "sim_s": 0.0,
                      "render_s": 0.0, "task_s": 0.0, "actors": 0, "retired": 0,
                      "peak_workers": 0}
        per_cpu = max(self.cpus_per_worker, 1e-9)
        self._grow(self.max_workers or max(1, int(cluster_cpus() // per_cpu)))
        self._start_reaper()

    # -- lifecycle ---------------------------------------------------------------------------------
    def _start_reaper(self) -> None:
        self._stop = threading.Event()
        self._reaper = None
        if self.idle_timeout_s is not None:
            self._reaper = threading.Thread(target=self._reap, name="simpool-idle", daemon=True)
            self._reaper.start()

    def _reap(self) -> None:
        every = min(1.0, max(0.05, self.idle_timeout_s / 4))
        while not self._stop.wait(every):
            try:
                self.retire_idle()
            except Exception:  # Ray shut down under us: nothing left to retire
                pass

    def _grow(self, n: int) -> None:
        """Ask for ``n`` more actors (placed when the cluster has room; pending until then)."""
        if n <= 0:
            return
        new = []
        for _ in range(n):
            h = _REMOTE_WORKER.options(**self._actor_options).remote(self.backend)
            new.append(_Actor(h, probe=h.info.remote()))
        with self._lock:
            for a in new:
                self._next_actor += 1
                self._actors[self._next_actor] = a
            self.stats["actors"] += n

    def _wanted(self) -> int:
        """How many more actors to ask for now that fresh work is queued."""
        if self.max_workers is not None:
            with self._lock:
                return self.max_workers - len(self._actors)
        now = time.monotonic()
        if now - self._followed < _FOLLOW_EVERY_S:
            return 0
        self._followed = now
        with self._lock:
            if len(self._actors) > self._started:  # ours are still pending: no more demand
                return 0
        free = ray.available_resources().get("CPU", 0.0)
        return int(free // max(self.cpus_per_worker, 1e-9))

    @property
    def size(self) -> int:
        """Actors asked for and not released: started ones and pending ones."""
        return len(self._actors)

    @property
    def started(self) -> int:
        """Actors that have answered and take work."""
        return self._started

    @property
    def _load(self) -> list[int]:
        with self._lock:
            return [a.load for a in self._actors.values()]

    def _probes(self) -> dict:
        """ObjectRef -> actor id of every outstanding probe (sends one where none is out)."""
        send = []
        with self._lock:
            if self._started == len(self._actors):
                return {}
            for k, a in self._actors.items():
                if not a.started and a.probe is None:
                    send.append((k, a))
        for k, a in send:
            ref = a.handle.info.remote()
            with self._lock:
                if self._actors.get(k) is a and not a.started and a.probe is None:
                    a.probe = ref
        with self._lock:
            return {a.probe: k for k, a in self._actors.items() if a.probe is not None}

    def _poll(self, timeout_s: float = 0.0) -> int:
        """Take in the probes that have answered (waiting up to ``timeout_s`` for one); returns how
        many actors started."""
        probes = self._probes()
        if not probes:
            return 0
        if timeout_s > 0:
            ray.wait(list(probes), num_returns=1, timeout=timeout_s)
        done, _ = ray.wait(list(probes), num_returns=len(probes), timeout=0)
        n = 0
        for ref in done:
            k = probes[ref]
            try:
                info = ray.get(ref)
            except ActorDiedError as exc:
                self._probe_failed(k, ref, exc, dead=True)
                continue
            except Exception as exc:  # restarting or unreachable: ask again
                self._probe_failed(k, ref, exc, dead=False)
                continue
            with self._lock:
                a = self._actors.get(k)
                if a is None or a.probe is not ref:
                    continue
                a.probe, a.started, a.info, a.failures = None, True, info, 0
                a.idle_since = time.monotonic()
                self._started += 1
                self.stats["peak_workers"] = max(self.stats["peak_workers"], self._started)
                n += 1
        return n

    def _probe_failed(self, k: int, ref, exc: BaseException, dead: bool) -> None:
        with self._lock:
            a = self._actors.get(k)
            if a is None or a.probe is not ref:
                return
            a.probe = None
            a.failures += 1
            # a restarting actor answers the next probe; a dead one fails every probe at once
            give_up = a.failures >= (2 if dead else _PROBE_FAILURES)
            if give_up:
                del self._actors[k]
                self.stats["replaced"] += 1
                lines = str(exc).strip().splitlines()
                self._last_death = lines[-1] if lines else type(exc).__name__
        if give_up:
            self._kill(a.handle)

    def _lost(self, k: int) -> None:
        """Actor ``k`` lost a task: take it out of service until a probe says it is back."""
        with self._lock:
            a = self._actors.get(k)
            if a is None or not a.started:
                return
            a.started = False
            a.probe = None  # the next _probes() sends one
            self._started -= 1

    @staticmethod
    def _kill(handle) -> None:
        if not ray.is_initialized():  # never start a Ray just to kill an actor of a gone one
            return
        try:
            ray.kill(handle, no_restart=True)
        except Exception:
            pass

    def retire_idle(self) -> int:
        """Kill the actors that have had nothing to do for ``idle_timeout_s`` while no caller had
        work queued (pending ones included); returns how many. Called every second by the pool's
        own thread when ``idle_timeout_s`` is set."""
        if self.idle_timeout_s is None or not ray.is_initialized():
            return 0
        now = time.monotonic()
        with self._lock:
            quiet = not self._demanding and now - self._last_demand >= self.idle_timeout_s
            gone = [k for k, a in self._actors.items()
                    if quiet and a.load == 0 and now - a.idle_since >= self.idle_timeout_s]
            victims = [self._actors.pop(k) for k in gone]
            self._started -= sum(1 for a in victims if a.started)
            self.stats["retired"] += len(victims)
        for a in victims:
            self._kill(a.handle)
        return len(victims)

    def ready(self, timeout_s: float | None = 120.0, at_least: int | None = None) -> list[dict]:
        """Wait until ``at_least`` actors (default: every one asked for) have started; returns the
        started ones' ``{"node", "pid", ...}``. Raises ``FarmError`` (one line, exit status 3) when
        they have not within ``timeout_s``: Ray starts workers at a low priority, so on cores that
        other jobs keep busy (or a cluster without free CPUs that adds none) they may not start."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        demand = [False]
        self._want(True, demand)  # a caller waiting for workers wants them
        try:
            return self._ready(deadline, timeout_s, at_least)
        finally:
            self._want(False, demand)

    def _ready(self, deadline: float | None, timeout_s: float | None,
               at_least: int | None) -> list[dict]:
        while True:
            self._poll()
            with self._lock:
                n, started = len(self._actors), self._started
            if n == 0:
                raise FarmError(f"the simulation workers could not start: {self._last_death}")
            need = n if at_least is None else min(max(1, at_least), n)
            if started >= need:
                break
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                what = (f"{n - started} of {n} simulation workers did not start" if at_least is None
                        else f"none of the {n} simulation workers started" if started == 0
                        else f"only {started} of the {at_least} simulation workers needed started")
                raise FarmError(f"{what} within {timeout_s:.0f} s: are other jobs using every "
                                f"core, or has the cluster no free CPUs? Run again when they are "
                                f"free, with fewer --workers or a longer --start-timeout")
            self._poll(min(_WAKE_S, left) if left is not None else _WAKE_S)
        with self._lock:
            return [dict(a.info) for a in self._actors.values() if a.started]

    def shutdown(self) -> None:
        """Kill the actors (the cluster itself is left alone)."""
        self._stop.set()
        with self._lock:
            actors = list(self._actors.values())
            self._actors, self._refs, self._started = {}, {}, 0
        for a in actors:
            self._kill(a.handle)

    def __enter__(self) -> "SimPool":
        return self

    def __exit__(self, *exc) -> None:
        self.shutdown()

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
        else:
            b = int(round(self.target_task_s / max(self._per_op_s, 1e-6)))
        b = max(1, min(b, self.max_batch))
        if remaining is not None:
            b = min(b, max(1, math.ceil(remaining / max(1, self._started))))
        return b

    def _submit(self, task: SimTask, avoid: int | None = None):
        """Send ``task`` to the least loaded started actor (not ``avoid`` if another has room);
        None when no actor has started."""
        with self._lock:
            best = None
            for k, a in self._actors.items():
                if a.started and (best is None or (k == avoid, a.load, k) < best[0]):
                    best = ((k == avoid, a.load, k), k, a)
            if best is None:
                return None
            _, k, a = best
            a.load += 1
            self.stats["tasks"] += 1
        return a.handle.run.remote(task), k

    def _release(self, k: int) -> None:
        with self._lock:
            a = self._actors.get(k)
            if a is not None and a.load > 0:
                a.load -= 1
                if a.load == 0:
                    a.idle_since = time.monotonic()

    def _want(self, on: bool, state: list[bool]) -> None:
        """Count a caller (``state[0]``: whether it counts now) among those with work queued: while
        any has, no actor is idle."""
        if on == state[0]:
            return
        with self._lock:
            self._demanding += 1 if on else -1
            self._last_demand = time.monotonic()
        state[0] = on

    def _demand(self, fresh: bool, retrying: bool) -> None:
        """A caller has work queued: ask for more actors when it is fresh input (a retried batch
        only needs one actor to exist)."""
        with self._lock:
            empty = not self._actors
            dead = self.stats["replaced"]
        if fresh:
            self._grow(self._wanted())
        elif retrying and empty:
            self._grow(1)
        if dead > 8 + 4 * (self.max_workers or 1) and not self._actors:
            raise FarmError(f"every simulation worker died ({dead} in all); the last: "
                            f"{self._last_death}")

    def stream(self, jobs: Iterable[Job], params: Any, *, images: bool = True,
               total: int | None = None, errors: str = "raise") -> Iterator[BatchResult]:
        """Label ``jobs`` and yield each completed batch (completion order).

        ``total`` (the number of jobs, when known) balances the last wave. Consecutive jobs of the
        same assembly share a task. A batch that fails in the simulator or is lost more than
        ``max_attempts`` times raises ``FarmError`` (``errors="raise"``) or is yielded as a
        ``BatchResult`` with no rows and ``error`` set, the stream going on (``errors="collect"``).
        Closing the generator cancels what is in flight.
        """
        if errors not in ("raise", "collect"):
            raise ValueError("errors must be 'raise' or 'collect'")
        if self._stop.is_set():
            raise RuntimeError("SimPool has been shut down")
        pjson = params_json(params)
        it = iter(jobs)
        head: list[Job] = []  # one look-ahead job that belongs to the next batch
        exhausted = False
        submitted = 0
        in_flight: dict[Any, tuple[SimTask, int, int]] = {}
        retry: deque[tuple[SimTask, int, int | None]] = deque()  # (task, attempt, actor to avoid)
        idle_since: float | None = None  # since when work has waited with no started actor
        demand = [False]  # whether this call counts among the pool's callers with work queued

        def next_task() -> SimTask | None:
            nonlocal exhausted, submitted
            remaining = None if total is None else max(1, total - submitted)
            want = self._batch_len(remaining)
            batch: list[Job] = head[:]
            head.clear()
            while len(batch) < want and not exhausted:
                try:
                    j = next(it)
                except StopIteration:
                    exhausted = True
                    break
                if batch and j.assembly.geometry_hash != batch[0].assembly.geometry_hash:
                    head.append(j)
                    break
                batch.append(j)
            if not batch:
                return None
            submitted += len(batch)
            a = batch[0].assembly
            with self._lock:
                self._next_task += 1
                task_id = self._next_task
            return SimTask(task_id=task_id, assembly_name=a.name,
                           geometry_hash=a.geometry_hash, assembly_ref=[self.put_assembly(a)],
                           operations=tuple(j.operation for j in batch),
                           keys=tuple(j.key for j in batch), seeds=tuple(j.seed for j in batch),
                           params=params, params_json=pjson, images=images)

        def lost(task: SimTask, attempt: int, exc: BaseException) -> str | None:
            """Requeue a lost batch; the error message when it has been lost too often."""
            if attempt >= self.max_attempts:
                return (f"a batch of {task.assembly_name} was lost {attempt} times "
                        f"({type(exc).__name__})")
            with self._lock:
                self.stats["resubmitted"] += 1
            retry.append((task, attempt + 1, None))
            return None

        try:
            while True:
                self._poll()
                fresh = bool(head) or not exhausted
                self._want(fresh or bool(retry), demand)
                if fresh or retry:
                    self._demand(fresh, bool(retry))
                cap = self._started * self.per_worker_in_flight
                while len(in_flight) < cap and (retry or head or not exhausted):
                    if retry:
                        task, attempt, avoid = retry.popleft()
                    else:
                        task, attempt, avoid = next_task(), 1, None
                        if task is None:
                            break
                    sent = self._submit(task, avoid)
                    if sent is None:  # the actors went away meanwhile
                        retry.appendleft((task, attempt, avoid))
                        break
                    in_flight[sent[0]] = (task, sent[1], attempt)
                if not in_flight:
                    if not retry and not head and exhausted:
                        return
                    now = time.monotonic()
                    idle_since = idle_since or now
                    if self.stall_timeout_s is not None and now - idle_since > self.stall_timeout_s:
                        raise FarmError(f"no simulation worker has been running for "
                                        f"{self.stall_timeout_s:.0f} s (lost nodes, or no free "
                                        f"CPUs on the cluster)")
                    self._poll(_WAKE_S)
                    continue
                idle_since = None
                probes = list(self._probes())
                done, _ = ray.wait(list(in_flight) + probes, num_returns=1, timeout=_WAKE_S)
                for ref in done:
                    if ref not in in_flight:  # an actor answered its probe: _poll takes it in
                        continue
                    task, k, attempt = in_flight.pop(ref)
                    self._release(k)
                    try:
                        res: BatchResult = ray.get(ref)
                    except RayTaskError as exc:  # the simulator raised: deterministic, do not retry
                        cause = str(exc.cause if getattr(exc, "cause", None) else exc).splitlines()
                        msg = (f"simulation of a batch of {task.assembly_name} failed: "
                               f"{cause[-1] if cause else type(exc).__name__}")
                        if errors == "raise":
                            raise FarmError(msg) from exc
                        yield self._failed(task, msg)
                        continue
                    except _LOST as exc:
                        self._lost(k)
                        msg = lost(task, attempt, exc)
                        if msg is None:
                            continue
                        if errors == "raise":
                            raise FarmError(msg) from exc
                        yield self._failed(task, msg)
                        continue
                    res.attempts = attempt
                    self._account(res)
                    yield res
        finally:
            self._want(False, demand)
            for ref in in_flight:
                try:
                    ray.cancel(ref)
                except Exception:
                    pass
            for _, k, _ in in_flight.values():
                self._release(k)

    @staticmethod
    def _failed(task: SimTask, msg: str) -> BatchResult:
        return BatchResult(task_id=task.task_id, table=rows_table([]), node="", pid=0,
                           assembly=task.assembly_name, error=msg)

    def _account(self, res: BatchResult) -> None:
        n = max(1, res.num_rows)
        per = res.task_s / n
        with self._lock:
            s = self.stats
            s["ops"] += res.num_rows
            s["sim_s"] += res.sim_s
            s["render_s"] += res.render_s
            s["task_s"] += res.task_s
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

    # A pool can be handed to another actor or task (e.g. the planning service): the actor
    # handles travel; object refs, probes and bookkeeping stay with the process that made them,
    # and the receiver probes the actors again.
    def __getstate__(self):
        d = self.__dict__.copy()
        for name in ("_lock", "_stop", "_reaper"):
            d.pop(name, None)
        d["_refs"] = {}
        d["_actors"] = {k: _Actor(a.handle) for k, a in self._actors.items()}
        d["_started"] = 0
        d["_demanding"] = 0
        return d

    def __setstate__(self, d):
        self.__dict__.update(d)
        self._lock = threading.Lock()
        self._last_demand = time.monotonic()
        self._start_reaper()
