"""``WorkerSet``: the simulation actors of a ``SimPool`` on an autoscaling cluster.

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
  dies fails at once, and the pool resubmits its batch to another started actor (with backoff, for
  as long as the pool makes progress: ``rap.farm.faults``) instead of letting Ray hold it until
  the actor has restarted on a node that may take minutes to come; the actor itself restarts
  (``max_restarts``) and rejoins when it answers a probe again, and one dead for good is replaced
  while fresh work is queued. A result never arrives twice for one submission, and the driver
  de-duplicates by key, so a run loses and duplicates no row.

Why not Ray Data's autoscaling actor pool (``map_batches`` with ``ActorPoolStrategy(min_size,
max_size)``), which does the same growing and shrinking: the planning service needs a warm pool
that answers many small concurrent batches in input order within milliseconds, and a Ray Data
execution starts its own executor and actor pool per dataset (seconds a batch where a warm
``SimPool`` takes the batch's own time: docs/RESULTS.md, ``benchmarks/farm_scale.py
--ray-data``); the driver needs resume by key, per-assembly failure isolation and bounded memory
on lazily selected operations, which ``SimPool.stream`` has. One pool for both keeps one code
path for labels, so the elastic behaviour is built here.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import ray
from ray.exceptions import ActorDiedError

from rap.errors import WorkFailedError

from rap.farm.actors import Backend, SimTask, SimWorker
from rap.farm.runtime import cluster_cpus

__all__ = ["WorkerSet", "FarmError", "IDLE_TIMEOUT_S", "WAKE_S"]

_REMOTE_WORKER = ray.remote(SimWorker)

IDLE_TIMEOUT_S = 60.0  # label's idle_timeout_s (then the autoscaler waits its own idle timeout)
WAKE_S = 1.0  # the stream's longest wait before it looks at probes, growth and stalls again
_FOLLOW_EVERY_S = 2.0  # workers=None: how often the cluster's free CPUs are read
_PROBE_FAILURES = 50  # failed probes (restarting, unreachable) before an actor is given up


class FarmError(WorkFailedError):
    """A batch that could not be labelled, or no worker to label it (exit status 3)."""


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


class WorkerSet:
    """The elastic set of ``SimWorker`` actors under a ``SimPool`` (its base class): actors asked
    for and probed, taken in as they start, released when idle, replaced when lost, and the least
    loaded chosen for each task. Parameters as ``SimPool``'s of the same names. Thread-safe: the
    bookkeeping is updated under ``_lock``, never held while waiting on Ray."""

    def __init__(self, workers: int | None = None, *, backend: Backend = Backend(),
                 max_restarts: int = 8, max_task_retries: int = 0, cpus_per_worker: float = 1.0,
                 idle_timeout_s: float | None = None, stall_timeout_s: float | None = None):
        if not ray.is_initialized():
            raise RuntimeError("SimPool needs Ray: call inside rap.farm.runtime.connect() or ray.init()")
        if workers is not None and int(workers) < 1:
            raise ValueError("workers must be >= 1")
        self.backend = backend
        self.max_workers = int(workers) if workers else None
        self.cpus_per_worker = float(cpus_per_worker)
        self.idle_timeout_s = idle_timeout_s
        self.stall_timeout_s = stall_timeout_s
        self._actor_options = dict(num_cpus=cpus_per_worker, max_restarts=max_restarts,
                                   max_task_retries=max_task_retries, scheduling_strategy="SPREAD")
        self._lock = threading.Lock()  # bookkeeping only (see rap.farm.pool's module doc)
        self._actors: dict[int, _Actor] = {}
        self._next_actor = 0
        self._started = 0
        self._refs: dict[str, Any] = {}  # geometry hash -> ObjectRef of the Assembly
        self._last_demand = time.monotonic()  # when the last caller stopped having work queued
        self._demanding = 0  # callers (streams, ready) that have work queued now
        self._followed = 0.0  # workers=None: when the free CPUs were last read
        self._last_death = ""  # why the last actor died for good (for the error of a dead pool)
        self.stats = {"tasks": 0, "resubmitted": 0, "lost": 0, "retried": 0, "redone_ops": 0,
                      "replaced": 0, "ops": 0, "sim_s": 0.0, "render_s": 0.0, "task_s": 0.0,
                      "actors": 0, "retired": 0, "peak_workers": 0}
        self._progress_at = time.monotonic()  # when a batch of this pool last completed
        per_cpu = max(self.cpus_per_worker, 1e-9)
        self._grow(self.max_workers or max(1, int(cluster_cpus() // per_cpu)))
        self._start_reaper()

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
    def _load(self) -> list[int]:  # tests
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
        try:  # never start a Ray just to kill an actor of a gone one
            if ray.is_initialized():
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
            self._poll(min(WAKE_S, left) if left is not None else WAKE_S)
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

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.shutdown()

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

    def _fetch(self, ref):
        """A task's result (``ray.get``): the one place it is fetched, the test seam of
        ``rap.farm.faults``."""
        return ray.get(ref)

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
        self._last_demand = self._progress_at = time.monotonic()  # this process's clock
        self._start_reaper()

