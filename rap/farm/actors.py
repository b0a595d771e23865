"""Simulation actors: each holds the assemblies it has seen and labels batches of operations.

A ``SimWorker`` is a long-lived Ray actor. A task (``SimTask``) names an assembly by geometry hash and
carries a reference to it in the object store (put once by the pool, fetched once per worker and
cached); it carries a batch of operations with their content keys and per-operation seeds, so a
label depends only on (root seed, content key), never on which worker ran it or when. Physics spaces
are built inside the worker by the simulator; nothing live crosses the wire. A task returns a
``BatchResult``: one row per operation in the dataset schema (``rap.dataset.SCHEMA``) plus timings.
A ``RolloutTask`` (chunks of whole-plan rollouts, ``rap.execution``) goes through the same actors
and the same retries; its outcomes come back in the result's ``extra["chunks"]``. So does a
``StepTask`` (one of ``STEP_FUNCTIONS`` per job: steps' simulated tolerances,
``rap.execution.tolerance``, or operations' perturbed-start successes,
``rap.execution.perturbed``), in ``extra["results"]``.

The simulator and renderer are looked up by import path (``Backend``), so the same actor serves the
real physics (the default) and anything with the same signatures. The backend's warm-up (loading
the compiled simulator: seconds on a busy machine) runs on a thread of the actor, so the actor
answers ``info`` (the pool's readiness probe) as soon as its process is up, and its first task
waits for the warm-up instead: ``rap-farm label --start-timeout`` counts until a worker runs, not
until its simulator is loaded.
"""

from __future__ import annotations

import os
import pickle
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import pyarrow as pa
import ray

from rap.operation import Operation

from rap.labelling.rows import Backend, label_rows, resolve, rows_table
from rap.farm.runtime import node_label

__all__ = ["Backend", "SimTask", "RolloutTask", "StepTask", "STEP_FUNCTIONS", "BatchResult", "SimWorker", "resolve", "pack",
           "unpack"]

_ASSEMBLY_CACHE = 32  # assemblies kept per worker (LRU, by geometry hash)


@dataclass(frozen=True)
class SimTask:
    """A batch of operations of one assembly. ``assembly_ref`` is a one-element list holding the
    ObjectRef, so Ray does not fetch the assembly for every task (the worker caches it)."""

    task_id: int
    assembly_name: str
    geometry_hash: str
    assembly_ref: list
    operations: tuple[Operation | bytes, ...]  # bytes: ``pack(operation)``
    keys: tuple[str, ...]
    seeds: tuple[int, ...]
    params: Any  # rap.sim.params.SimParams
    params_json: str
    images: bool = True


@dataclass(frozen=True)
class RolloutTask:
    """Chunks of whole-plan rollouts (``rap.execution.rollout``) of one plan: ``work`` holds
    ``(first, count)`` per chunk; ``keys`` names them (the pool's retry bookkeeping)."""

    task_id: int
    assembly_name: str
    geometry_hash: str
    assembly_ref: list
    plan: Any  # rap.execution.rollout.RolloutPlan
    root_seed: int
    work: tuple[tuple[int, int], ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(f"rollouts {f}-{f + c - 1}" for f, c in self.work)


#: what a ``StepTask`` may run per job, by name: ``(module, function)``, called with the task's
#: assembly and then the job's arguments
STEP_FUNCTIONS = {"tolerance": ("rap.execution.tolerance", "tolerance"),
                  "perturbed": ("rap.execution.perturbed", "perturbed_successes")}


@dataclass(frozen=True)
class StepTask:
    """Jobs of one of ``STEP_FUNCTIONS`` (``function``) on one assembly: each job is the
    function's arguments after the assembly; ``names`` names them (the retries')."""

    task_id: int
    assembly_name: str
    geometry_hash: str
    assembly_ref: list
    function: str
    jobs: tuple[tuple, ...]
    names: tuple[str, ...]

    def __post_init__(self):
        if self.function not in STEP_FUNCTIONS:
            raise ValueError(f"step task function {self.function!r}: one of "
                             f"{', '.join(STEP_FUNCTIONS)}")

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(f"{self.function} {n}" for n in self.names)


def pack(operation: Operation) -> bytes:
    """An operation as it may travel in a ``SimTask``: its pickle, which the driver forwards as
    opaque bytes (a chunk of packed operations crosses the driver at memcpy speed, where
    Operations with their Fractions cost it ~15 us each to unpickle and pickle again)."""
    return pickle.dumps(operation, protocol=pickle.HIGHEST_PROTOCOL)


def unpack(operation: Operation | bytes) -> Operation:
    """The operation of a ``SimTask`` entry (``pack``'s bytes or the Operation itself)."""
    return pickle.loads(operation) if isinstance(operation, bytes) else operation


@dataclass
class BatchResult:
    """What a task returns: its rows as one table in ``rap.labelling.rows.WIRE_SCHEMA`` (``image`` null
    when images were not asked for), in the task's order, and where the time went. The table is
    built on the worker, so the driver never handles a row as a Python object (``rows`` does, for
    callers that want dicts)."""

    task_id: int
    table: pa.Table
    node: str
    pid: int
    assembly: str = ""  # the task's assembly name
    error: str | None = None  # set (rows empty) when the pool collects a failed batch
    sim_s: float = 0.0  # inside simulate()
    render_s: float = 0.0  # inside render()
    task_s: float = 0.0  # the whole actor method, fetch of the assembly included
    attempts: int = 1  # set by the pool
    extra: dict = field(default_factory=dict)

    @property
    def num_rows(self) -> int:
        return self.table.num_rows

    @property
    def rows(self) -> list[dict]:
        """The rows as dicts (``WIRE_SCHEMA``'s columns); O(rows) each call."""
        return self.table.to_pylist()


class SimWorker:
    """Actor body (wrapped with ``ray.remote`` by the pool with its retry options)."""

    def __init__(self, backend: Backend = Backend()):
        self._backend = backend
        self._simulate = None
        self._render = None
        self._assemblies: OrderedDict[str, Any] = OrderedDict()
        self._node = node_label()
        self._pid = os.getpid()
        self._warm_s = 0.0
        self._warm_error: BaseException | None = None
        self._warming: threading.Thread | None = None
        if getattr(backend, "warm_up", ""):
            self._warming = threading.Thread(target=self._warm_up, name="warm-up", daemon=True)
            self._warming.start()

    def _warm_up(self) -> None:
        try:
            self._warm_s = resolve(self._backend.warm_up)()
        except BaseException as exc:  # raised again by the first task, where the pool sees it
            self._warm_error = exc

    def info(self) -> dict:
        """Where this worker runs (also a readiness probe; ``warm_up_s`` is 0 while warming)."""
        return {"node": self._node, "pid": self._pid, "warm_up_s": self._warm_s}

    def _functions(self, images: bool):
        if self._warming is not None:
            self._warming.join()
            self._warming = None
        if self._warm_error is not None:
            raise self._warm_error
        if self._simulate is None:
            self._simulate = resolve(self._backend.simulate)
        if images and self._render is None:
            self._render = resolve(self._backend.render)
        return self._simulate, self._render

    def _assembly(self, task: SimTask):
        a = self._assemblies.get(task.geometry_hash)
        if a is None:
            a = ray.get(task.assembly_ref[0])
            self._assemblies[task.geometry_hash] = a
            while len(self._assemblies) > _ASSEMBLY_CACHE:
                self._assemblies.popitem(last=False)
        else:
            self._assemblies.move_to_end(task.geometry_hash)
        return a

    def run(self, task: SimTask | RolloutTask | StepTask) -> BatchResult:
        if isinstance(task, RolloutTask):
            return self._rollouts(task)
        if isinstance(task, StepTask):
            return self._steps(task)
        t0 = time.perf_counter()
        simulate, render = self._functions(task.images)
        assembly = self._assembly(task)
        rows, sim_s, render_s = label_rows(
            assembly, [unpack(op) for op in task.operations], task.keys, task.seeds, task.params, task.params_json,
            simulate=simulate, render=render if task.images else None, node=self._node,
            assembly_name=task.assembly_name, geometry_hash=task.geometry_hash)
        return BatchResult(task_id=task.task_id, table=rows_table(rows), node=self._node,
                           pid=self._pid,
                           assembly=task.assembly_name, sim_s=sim_s, render_s=render_s, task_s=time.perf_counter() - t0)

    def _rollouts(self, task: RolloutTask) -> BatchResult:
        """A ``RolloutTask``'s chunks; their ``ChunkOutcome`` s in ``extra["chunks"]``."""
        from rap.execution.rollout import run_chunks

        t0 = time.perf_counter()
        self._functions(False)  # the simulator loaded (warm-up joined)
        out = run_chunks(self._assembly(task), task.plan, task.root_seed, task.work)
        dt = time.perf_counter() - t0
        return BatchResult(task_id=task.task_id, table=rows_table([]), node=self._node,
                           pid=self._pid, assembly=task.assembly_name, sim_s=dt, task_s=dt,
                           extra={"chunks": out})

    def _steps(self, task: StepTask) -> BatchResult:
        """A ``StepTask``'s results, in its jobs' order, in ``extra["results"]``."""
        import importlib

        module, name = STEP_FUNCTIONS[task.function]
        function = getattr(importlib.import_module(module), name)
        t0 = time.perf_counter()
        self._functions(False)
        assembly = self._assembly(task)
        out = [function(assembly, *job) for job in task.jobs]
        dt = time.perf_counter() - t0
        return BatchResult(task_id=task.task_id, table=rows_table([]), node=self._node,
                           pid=self._pid, assembly=task.assembly_name, sim_s=dt, task_s=dt,
                           extra={"results": out})
