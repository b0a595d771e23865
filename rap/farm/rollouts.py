"""Whole-plan rollouts on the farm's pool: ``PoolRollouts``, a ``RolloutRunner``
(``rap.execution.sequence``), a ``ToleranceRunner`` (``rap.execution.tolerance``: one task a
step) and a ``PerturbedRunner`` (``rap.execution.perturbed``: one task per batch of operations)
over a ``SimPool``.

Each chunk of rollouts (``rap.execution.rollout.CHUNK`` consecutive indices) is one task on the
same simulation actors that label operations and serve the planner's simulator fallback, with the
pool's retries, in-flight limit and growth with the cluster (``SimPool.run_tasks``). A chunk's
outcome depends only on the plan, the root seed and its indices, so the figures are the same on 1
worker or 200, in any order. ``on_chunk(done, total)`` is called as chunks complete (progress).

Cost: one ``ray.put`` of the assembly per pool; one task per chunk (0.1-2 s of work each), per
step's tolerance (about a second each: some 200 trials) or per ``PERTURBED_BATCH`` operations
simulated once from a perturbed start (about 0.15 s each).
"""

from __future__ import annotations

from typing import Callable, Sequence

from rap.assembly import Assembly
from rap.execution.rollout import ChunkOutcome, RolloutPlan
from rap.farm.actors import RolloutTask, StepTask
from rap.farm.pool import SimPool
from rap.farm.workers import FarmError

__all__ = ["PoolRollouts", "PERTURBED_BATCH"]

PERTURBED_BATCH = 8  # operations a perturbed-start task simulates (about a second of work)


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
        return self._step_jobs("tolerance", jobs, 1, lambda k: f"step {k + 1}")

    def run_perturbed(self, jobs: Sequence[tuple]) -> list[int]:
        """``rap.execution.perturbed.perturbed_successes(*job)`` for each job, ``PERTURBED_BATCH``
        jobs a pool task; results in the order of ``jobs``. Every job is on one assembly."""
        return self._step_jobs("perturbed", jobs, PERTURBED_BATCH, lambda k: f"operation {k + 1}")

    def _step_jobs(self, function: str, jobs: Sequence[tuple], batch: int, name) -> list:
        """``jobs`` (each ``(assembly, *arguments)``, one assembly) as ``StepTask`` s of up to
        ``batch`` jobs; the results in the order of ``jobs``."""
        if not jobs:
            return []
        assembly = jobs[0][0]
        ref = [self.pool.put_assembly(assembly)]
        tasks = [StepTask(self.pool.next_task_id(), assembly.name, assembly.geometry_hash, ref,
                          function, tuple(tuple(job[1:]) for job in jobs[i:i + batch]),
                          tuple(name(k) for k in range(i, min(i + batch, len(jobs)))))
                 for i in range(0, len(jobs), batch)]
        start = {t.task_id: i * batch for i, t in enumerate(tasks)}
        got: dict[int, object] = {}
        for res in self.pool.run_tasks(tasks):
            if res.error:
                raise FarmError(res.error)
            for j, value in enumerate(res.extra["results"]):
                got[start[res.task_id] + j] = value
        return [got[k] for k in range(len(jobs))]
