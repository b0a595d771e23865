"""A plan's sequence success: rollouts until its 95% interval is narrow enough, and per step how
often it succeeds once reached.

``measure(assembly, plan, runner, root_seed)`` runs rollouts (``rap.execution.rollout``) in fixed
waves of indices, ``WAVES`` = 100, 200, ... 600, 800 rollouts in all, and stops after the first
wave whose Clopper-Pearson half-width is at most ``half_width`` (0.05 by default: about 400
rollouts at a success near one half, 100 near 0 or 1), or at ``max_rollouts``. The waves, and so
the stopping point, depend only on the results, which depend only on the root seed and the
plan: the same figure with 1 worker or 200.

A ``runner`` runs chunks of rollouts (``RolloutRunner``): ``InProcess`` here, the local
simulator's worker processes (``rap.plan.scoring.local_simulator``), or the farm's pool
(``rap.farm.rollouts``). ``on_progress(done, planned)`` is called after each wave.

Cost: the rollouts (``rap.execution.rollout``); the bookkeeping is O(rollouts).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Protocol, Sequence

from rap.assembly import Assembly
from rap.execution.rollout import ChunkOutcome, RolloutPlan, chunks, run_chunks
from rap.stats import Rate, rate

__all__ = ["RolloutRunner", "InProcess", "SequenceMeasure", "measure", "WAVES", "HALF_WIDTH"]

WAVES = (100, 200, 300, 400, 500, 600, 800)  # rollouts in all after each wave
HALF_WIDTH = 0.05  # the default target: the 95% interval of sequence success within +-0.05


class RolloutRunner(Protocol):
    def run_rollouts(self, assembly: Assembly, plan: RolloutPlan, root_seed: int,
                     work: Sequence[tuple[int, int]]) -> list[ChunkOutcome]: ...


class InProcess:
    """A ``RolloutRunner`` in this process, chunk after chunk."""

    def run_rollouts(self, assembly: Assembly, plan: RolloutPlan, root_seed: int,
                     work: Sequence[tuple[int, int]]) -> list[ChunkOutcome]:
        return run_chunks(assembly, plan, root_seed, work)


@dataclass(frozen=True)
class SequenceMeasure:
    """What the rollouts of one plan measured: the whole plan's ``success`` (a ``Rate``), per step
    the rollouts that reached it (``step_tried``) and failed there (``step_failed``)."""

    success: Rate
    step_tried: tuple[int, ...]
    step_failed: tuple[int, ...]
    seconds: float

    @property
    def rollouts(self) -> int:
        return self.success.trials

    def step_rate(self, k: int) -> Rate | None:
        """Step ``k``'s success once reached (None: no rollout reached it)."""
        tried = self.step_tried[k]
        return rate(tried - self.step_failed[k], tried) if tried else None

    def to_dict(self) -> dict:
        return {**self.success.to_dict(), "rollouts": self.rollouts,
                "seconds": round(self.seconds, 3)}


def tally(steps: int, outcomes: Sequence[ChunkOutcome]) -> tuple[int, list[int], list[int], int]:
    """(successes, tried per step, failed per step, rollouts) of ``outcomes``."""
    tried, failed = [0] * steps, [0] * steps
    wins = runs = 0
    for out in outcomes:
        for f in out.failed_at:
            runs += 1
            last = steps - 1 if f < 0 else f
            for k in range(last + 1):
                tried[k] += 1
            if f < 0:
                wins += 1
            else:
                failed[f] += 1
    return wins, tried, failed, runs


def measure(assembly: Assembly, plan: RolloutPlan, runner: RolloutRunner, root_seed: int, *,
            half_width: float = HALF_WIDTH, max_rollouts: int = WAVES[-1],
            rollouts: int | None = None, prior: Sequence[ChunkOutcome] = (),
            on_progress: Callable[[int, int], None] | None = None) -> SequenceMeasure:
    """Sequence success of ``plan`` (module doc). ``rollouts``: exactly that many instead (no
    stopping rule). ``prior``: the outcomes of rollouts ``0 .. m - 1`` already run on this root
    seed (a whole number of waves' chunks); the waves go on from there."""
    t0 = time.perf_counter()
    if rollouts is not None:
        waves = (int(rollouts),)
    else:
        waves = tuple(w for w in WAVES if w < max_rollouts) + (int(max_rollouts),)
    if waves[0] < 1:
        raise ValueError("at least one rollout")
    outcomes: list[ChunkOutcome] = list(prior)
    done = sum(len(o.failed_at) for o in outcomes)
    if done:
        wins, _, _, runs = tally(len(plan.steps), outcomes)
        if rate(wins, runs).half_width <= half_width or done >= waves[-1]:
            waves = ()
    for target in (w for w in waves if w > done):
        outcomes += runner.run_rollouts(assembly, plan, root_seed, chunks(done, target))
        done = target
        if on_progress is not None:
            on_progress(done, waves[-1])
        wins, tried, failed, runs = tally(len(plan.steps), outcomes)
        if rate(wins, runs).half_width <= half_width:
            break
    wins, tried, failed, runs = tally(len(plan.steps), outcomes)
    return SequenceMeasure(rate(wins, runs), tuple(tried), tuple(failed),
                           time.perf_counter() - t0)
