"""Selection in parallel: each assembly's operations selected by a Ray task of its own.

``parallel_jobs(plan, summary, skipped, tasks=N)`` yields exactly the jobs of
``rap.labelling.selection.iter_jobs(plan, summary, skipped)`` (every selected operation not yet in the
dataset, once, with the same content key and seed, and the same ``summary`` counts: existing,
short and failed selections), but the selecting (counting the space and building the NDBG,
sampling or enumerating partitions, hashing keys: the driver's largest cost per row) runs in up
to ``N`` Ray tasks at once, one per assembly, on any node. The driver's thread only turns chunks of
``(operation, key, seed)`` back into jobs, the operations packed (``rap.farm.actors.pack``: the
driver forwards them to the workers without unpickling and pickling them again). Assemblies interleave in the order their chunks arrive;
a label depends on neither (root seed and content key only).

Each task is a streaming generator (``CHUNK`` jobs a chunk, at most ``AHEAD`` chunks ahead of the
driver: Ray's generator backpressure), so memory stays bounded by the chunks in flight, not by any
operation space. The tasks ask for no CPU (``num_cpus=0``): a cluster whose CPUs all hold
simulation actors still selects, and the driver's own CPU is freed for dispatch and writing.
Closing the generator (an interrupted run) cancels the tasks. Cost: one task and one ``ray.put``
of the dataset's keys per run, and per chunk a transfer of its operations.
"""

from __future__ import annotations

from typing import Callable, Iterator

import ray

from rap.farm.actors import pack
from rap.labelling.selection import (Job, LabelPlan, LabelSummary, Outcome, recount, record,
                               select_jobs)

__all__ = ["parallel_jobs", "CHUNK", "AHEAD"]

CHUNK = 256  # jobs a chunk
AHEAD = 4  # chunks a task may run ahead of the driver


@ray.remote(num_cpus=0, max_retries=3, _generator_backpressure_num_objects=AHEAD)
def _select(plan: LabelPlan, name: str, chunk: int):
    """Yield ``("jobs", [(packed operation, key, seed), ...], outcome)`` chunks of one assembly
    (the outcome so far: its counted total, existing keys), then ``("done", None, outcome)``."""
    assembly = next(a for a in plan.assemblies if a.name == name)
    outcome = Outcome()
    buf: list = []
    for op, key, seed in select_jobs(plan, assembly, outcome):
        buf.append((pack(op), key, seed))  # the driver passes it on to a worker unread
        if len(buf) >= chunk:
            yield "jobs", buf, outcome
            buf = []
    yield "jobs", buf, outcome
    yield "done", None, outcome


def parallel_jobs(plan: LabelPlan, summary: LabelSummary, skipped: Callable[[int], None],
                  tasks: int = 2, chunk: int = CHUNK,
                  recounted: Callable[[], None] = lambda: None) -> Iterator[Job]:
    """The jobs of ``iter_jobs``, selected by up to ``tasks`` Ray tasks at once (module doc).

    A selection the plan left uncounted (``rap.enumerate.defer_selection``) is counted by its
    task; when it takes fewer operations than the plan's upper bound, ``summary.total`` falls by
    the difference and ``recounted()`` is called (to resize a progress bar): ``recount``."""
    # the plan travels once (its dataset lock stays with the driver: a lock is not pickled)
    shipped = ray.put(_portable(plan))
    by_name = {a.name: a for a in plan.assemblies}
    waiting = [a.name for a in plan.assemblies]
    running: dict = {}  # generator -> [assembly name, existing counted, total counted]

    def start() -> None:
        while waiting and len(running) < max(1, tasks):
            name = waiting.pop(0)
            running[_select.remote(shipped, name, chunk)] = [name, 0, False]

    start()
    try:
        while running:
            ready, _ = ray.wait(list(running), num_returns=1)
            for gen in ready:
                name, counted, totalled = running[gen]
                try:
                    kind, payload, outcome = ray.get(next(gen))
                except StopIteration:
                    del running[gen]
                    start()
                    continue
                if not totalled and outcome.total is not None:
                    running[gen][2] = True
                    if recount(summary, plan, name, outcome):
                        recounted()
                if outcome.existing > counted:
                    summary.existing += outcome.existing - counted
                    skipped(outcome.existing - counted)
                    running[gen][1] = outcome.existing
                if kind == "done":
                    record(summary, name, outcome)
                    continue
                assembly = by_name[name]
                for op, key, seed in payload:
                    if name in summary.failed:  # failed while simulating: drop the rest
                        break
                    yield Job(assembly, op, key, seed)
    finally:  # also when closed after Ray has gone (then there is nothing left to cancel)
        for gen in running:
            try:
                ray.cancel(gen)
            except Exception:
                pass


def _portable(plan: LabelPlan) -> LabelPlan:
    """The plan without its lock (the driver keeps the dataset's lock; tasks only read)."""
    from dataclasses import replace

    return replace(plan, lock=None)
