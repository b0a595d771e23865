"""Whole-plan rollouts on the farm's pool: ``PoolRollouts``, a ``RolloutRunner``
(``rap.execution.sequence``) and a ``ToleranceRunner`` (``rap.execution.tolerance``: one task a
step) over a ``SimPool``.

Each chunk of rollouts (``rap.execution.rollout.CHUNK`` consecutive indices) is one task on the
same simulation actors that label operations and serve the planner's simulator fallback, with the
pool's retries, in-flight limit and growth with the cluster (``SimPool.run_tasks``). A chunk's
outcome depends only on the plan, the root seed and its indices, so the figures are the same on 1
worker or 200, in any order. ``on_chunk(done, total)`` is called as chunks complete (progress).

Cost: one ``ray.put`` of the assembly per pool; one task per chunk (0.1-2 s of work each) or per
step's tolerance (about a second each: some 200 trials).
"""

from __future__ import annotations

from typing import Callable, Sequence

from rap.assembly import Assembly
from rap.execution.rollout import ChunkOutcome, RolloutPlan
from rap.farm.actors import RolloutTask, ToleranceTask
from rap.farm.pool import SimPool
from rap.farm.workers import FarmError

__all__ = ["PoolRollouts"]


class PoolRollouts:
    """``run_rollouts`` on ``pool`` (module doc)."""

    def __init__(self, pool: SimPool, on_chunk: Callable[[int, int], None] | None = None):
        self.pool = pool
        self.on_chunk = on_chunk

    def run_rollouts(self, assembly: Assembly, plan: RolloutPlan, root_seed: int,
                     work: Sequence[tuple[int, int]]) -> list[ChunkOutcome]:
        ref = [self.pool.put_assembly(assembly)]
        tasks = [RolloutTask(self.pool.next_task_id(), assembly.name, assembly.geometry_hash,
                             ref, plan, int(root_seed), (w,)) for w in work]
        got: dict[int, ChunkOutcome] = {}
        for res in self.pool.run_tasks(tasks):
            if res.error:
                raise FarmError(res.error)
            for out in res.extra["chunks"]:
                got[out.first] = out
            if self.on_chunk is not None:
                self.on_chunk(len(got), len(tasks))
        return [got[first] for first, _ in work]

    def run_tolerances(self, jobs: Sequence[tuple]) -> list[float]:
        """``rap.execution.tolerance.tolerance(*job)`` for each job, one pool task each (the
        steps in parallel on the pool's actors); results in the order of ``jobs``. Every job is
        on one assembly (a plan's steps)."""
        if not jobs:
            return []
        assembly = jobs[0][0]
        ref = [self.pool.put_assembly(assembly)]
        tasks = [ToleranceTask(self.pool.next_task_id(), assembly.name, assembly.geometry_hash,
                               ref, (tuple(job[1:]),), (f"step {k + 1}",))
                 for k, job in enumerate(jobs)]
        order = {t.task_id: k for k, t in enumerate(tasks)}
        got: dict[int, float] = {}
        for res in self.pool.run_tasks(tasks):
            if res.error:
                raise FarmError(res.error)
            got[order[res.task_id]] = res.extra["tolerances"][0]
        return [got[k] for k in range(len(tasks))]
