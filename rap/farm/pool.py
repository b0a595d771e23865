"""``SimPool``: a reusable pool of simulation actors shared by the labelling farm and the planner.

Usage (Ray already initialised, e.g. inside ``rap.farm.runtime.connect()``)::

    pool = SimPool(workers=4)                          # 4 actors, one CPU each, spread over nodes
    results = pool.score(assembly, ops, params, root_seed)       # list[Scored], input order
    for batch in pool.stream(pool.jobs(assembly, ops, params, root_seed)):   # completion order
        ...                                            # batch.rows: dataset rows
    pool.shutdown()

Design (Ray's core patterns):

* every assembly is ``ray.put`` once per pool (cached by geometry hash) and fetched once per worker;
* operations are batched per task; with ``batch_size=None`` the batch adapts so that a task runs
  about ``target_task_s`` (well over Ray's per-task overhead) and the last wave splits evenly;
* at most ``per_worker_in_flight`` tasks per actor are in flight (``ray.wait``); jobs are pulled from
  the input iterator only when there is room, so the driver's memory does not grow with the input;
* a task lost with its worker is retried by Ray (``max_restarts`` / ``max_task_retries``) and, if
  that fails too, resubmitted by the pool to another actor (``max_attempts``); a result never
  arrives twice for one submission, and callers that need exactly-once de-duplicate by key;
* a label depends only on (root seed, content key): never on the worker count or completion order;
* one pool serves concurrent callers (threads of the planning service): each ``stream``/``score``
  call waits on its own tasks, and the shared bookkeeping (actor loads, assembly references, task
  ids, statistics) is updated under one short lock, never held while waiting on Ray.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Iterable, Iterator, Sequence

import ray
from ray.exceptions import (ActorDiedError, ActorUnavailableError, NodeDiedError, ObjectLostError,
                            OwnerDiedError, RayActorError, RayTaskError, WorkerCrashedError)

from rap.assembly import Assembly
from rap.enumerate import label_key, label_seed
from rap.errors import RapError
from rap.operation import Operation

from rap.farm.actors import Backend, BatchResult, SimTask, SimWorker
from rap.farm.rows import params_json
from rap.farm.selection import Job
from rap.farm.runtime import cluster_cpus

__all__ = ["SimPool", "Job", "Scored", "FarmError", "params_json"]

_REMOTE_WORKER = ray.remote(SimWorker)

_LOST = (RayActorError, ActorDiedError, ActorUnavailableError, WorkerCrashedError, NodeDiedError,
         ObjectLostError, OwnerDiedError)


class FarmError(RapError):
    """A batch that could not be labelled (exit status 1 is for plans; this one is 3)."""

    exit_code = 3


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


class SimPool:
    """A set of ``SimWorker`` actors with batching, bounded in-flight tasks and retries.

    Parameters: ``workers`` (default: every CPU of the cluster), ``backend`` (simulator/renderer
    import paths), ``batch_size`` (None: adaptive), ``target_task_s``, ``max_batch``,
    ``per_worker_in_flight``, ``max_attempts`` (submissions of one batch by the pool),
    ``max_restarts``/``max_task_retries`` (Ray's own actor fault tolerance), ``cpus_per_worker``.
    """

    def __init__(self, workers: int | None = None, *, backend: Backend = Backend(),
                 batch_size: int | None = None, target_task_s: float = 1.0, max_batch: int = 64,
                 per_worker_in_flight: int = 2, max_attempts: int = 4, max_restarts: int = 8,
                 max_task_retries: int = 2, cpus_per_worker: float = 1.0):
        if not ray.is_initialized():
            raise RuntimeError("SimPool needs Ray: call inside rap.farm.runtime.connect() or ray.init()")
        n = int(workers) if workers else cluster_cpus()
        if n < 1:
            raise ValueError("workers must be >= 1")
        if batch_size is not None and batch_size < 1:
            raise ValueError("batch_size must be >= 1")
        self.backend = backend
        self.batch_size = batch_size
        self.target_task_s = float(target_task_s)
        self.max_batch = int(max_batch)
        self.per_worker_in_flight = max(1, int(per_worker_in_flight))
        self.max_attempts = max(1, int(max_attempts))
        self._actor_options = dict(num_cpus=cpus_per_worker, max_restarts=max_restarts,
                                   max_task_retries=max_task_retries, scheduling_strategy="SPREAD")
        self._lock = threading.Lock()  # bookkeeping only (see module doc)
        self._actors = [self._new_actor() for _ in range(n)]
        self._load = [0] * n
        self._refs: dict[str, Any] = {}  # geometry hash -> ObjectRef of the Assembly
        self._next_task = 0
        self._per_op_s: float | None = None  # moving average of task seconds per operation
        self.stats = {"tasks": 0, "resubmitted": 0, "replaced": 0, "ops": 0, "sim_s": 0.0,
                      "render_s": 0.0, "task_s": 0.0}

    # -- lifecycle ---------------------------------------------------------------------------------
    def _new_actor(self):
        return _REMOTE_WORKER.options(**self._actor_options).remote(self.backend)

    @property
    def size(self) -> int:
        return len(self._actors)

    def ready(self, timeout_s: float | None = 120.0) -> list[dict]:
        """Wait until every actor has started; returns their ``{"node", "pid"}``. Raises
        ``FarmError`` (one line, exit status 3) when they have not within ``timeout_s``: Ray
        starts workers at a low priority, so on cores that other jobs keep busy (or a cluster
        without free CPUs) they may not start at all."""
        refs = [a.info.remote() for a in self._actors]
        done, _ = ray.wait(refs, num_returns=len(refs), timeout=timeout_s)
        if len(done) < len(refs):
            raise FarmError(f"{len(refs) - len(done)} of {len(refs)} simulation workers did not "
                            f"start within {timeout_s:.0f} s: are other jobs using every core, "
                            f"or has the cluster no free CPUs? Run again when they are free, "
                            f"with fewer --workers or a longer --start-timeout")
        return ray.get(refs)

    def shutdown(self) -> None:
        """Kill the actors (the cluster itself is left alone)."""
        for a in self._actors:
            try:
                ray.kill(a, no_restart=True)
            except Exception:
                pass
        with self._lock:
            self._actors, self._load, self._refs = [], [], {}

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
            b = min(b, max(1, math.ceil(remaining / self.size)))
        return b

    def _submit(self, task: SimTask, avoid: int | None = None):
        with self._lock:
            i = min(range(self.size), key=lambda k: (k == avoid, self._load[k], k))
            self._load[i] += 1
            self.stats["tasks"] += 1
            actor = self._actors[i]
        return actor.run.remote(task), i

    def _release(self, i: int) -> None:
        with self._lock:
            if 0 <= i < len(self._load):
                self._load[i] -= 1

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
        if not self._actors:
            raise RuntimeError("SimPool has been shut down")
        pjson = params_json(params)
        it = iter(jobs)
        head: list[Job] = []  # one look-ahead job that belongs to the next batch
        exhausted = False
        submitted = 0
        in_flight: dict[Any, tuple[SimTask, int, int]] = {}
        cap = self.size * self.per_worker_in_flight

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

        try:
            while True:
                while len(in_flight) < cap and (head or not exhausted):
                    task = next_task()
                    if task is None:
                        break
                    ref, i = self._submit(task)
                    in_flight[ref] = (task, i, 1)
                if not in_flight:
                    return
                done, _ = ray.wait(list(in_flight), num_returns=1)
                for ref in done:
                    task, i, attempt = in_flight.pop(ref)
                    self._release(i)
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
                        if attempt >= self.max_attempts:
                            msg = (f"a batch of {task.assembly_name} was lost {attempt} times "
                                   f"({type(exc).__name__})")
                            if errors == "raise":
                                raise FarmError(msg) from exc
                            yield self._failed(task, msg)
                            continue
                        self._maybe_replace(i, exc)
                        with self._lock:
                            self.stats["resubmitted"] += 1
                        ref2, j = self._submit(task, avoid=i)
                        in_flight[ref2] = (task, j, attempt + 1)
                        continue
                    res.attempts = attempt
                    self._account(res)
                    yield res
        finally:
            if in_flight:
                for ref in in_flight:
                    try:
                        ray.cancel(ref)
                    except Exception:
                        pass
                for _, i, _ in in_flight.values():
                    self._release(i)

    @staticmethod
    def _failed(task: SimTask, msg: str) -> BatchResult:
        return BatchResult(task_id=task.task_id, rows=[], node="", pid=0,
                           assembly=task.assembly_name, error=msg)

    def _account(self, res: BatchResult) -> None:
        n = max(1, len(res.rows))
        per = res.task_s / n
        with self._lock:
            s = self.stats
            s["ops"] += len(res.rows)
            s["sim_s"] += res.sim_s
            s["render_s"] += res.render_s
            s["task_s"] += res.task_s
            self._per_op_s = per if self._per_op_s is None else 0.7 * self._per_op_s + 0.3 * per

    def _maybe_replace(self, i: int, exc: BaseException) -> None:
        """Replace actor ``i`` when Ray says it is dead for good (restarts exhausted)."""
        if not isinstance(exc, ActorDiedError):
            return
        try:
            ray.get(self._actors[i].info.remote(), timeout=30)
            return  # it came back (restarted)
        except Exception:
            pass
        with self._lock:
            dead = self._actors[i]
            self._actors[i] = self._new_actor()
            self.stats["replaced"] += 1
        try:
            ray.kill(dead, no_restart=True)
        except Exception:
            pass

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
    # handles travel; object refs and bookkeeping stay with the process that made them.
    def __getstate__(self):
        d = self.__dict__.copy()
        d["_refs"] = {}
        d["_load"] = [0] * len(self._actors)
        del d["_lock"]
        return d

    def __setstate__(self, d):
        self.__dict__.update(d)
        self._lock = threading.Lock()
