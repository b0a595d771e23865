"""The whole plan in the planar simulator, each step starting where the earlier ones left the parts:
``run_planar``, the robot's view of ``rap.execution`` (its one home: rollouts, carried poses, the
error model, seeds).

``run_planar(plan, assembly, trials=N, seed=S)`` runs N rollouts of the plan's steps
(``rap.execution.rollout``: step k is one simulator trial from where this rollout's earlier steps
left the parts, with the part off its place by a draw of ``errors``); ``trials=None`` runs waves
until the 95% interval is within +-0.05 (``rap.execution.sequence``). ``errors`` defaults to none
(``ErrorModel.zero()``: carried noise alone); ``carry=False`` is the control in which every step
starts exactly in place, as R assumes. ``runner``: where the rollouts run (this process by default;
the local workers or the farm's pool, ``rap.commands._rollouts``).

Returns a ``PlanarOutcome``: the success (a ``Rate`` with its interval), per-step reached and failed
counts, seconds. Cost: ``rap.execution.rollout``.
"""

from __future__ import annotations

from dataclasses import dataclass

from rap.assembly import Assembly
from rap.execution.error_model import ErrorModel
from rap.execution.rollout import RolloutPlan
from rap.execution.sequence import InProcess, RolloutRunner, measure
from rap.plan.report.result import PlanResult
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.stats import Rate

__all__ = ["PlanarOutcome", "run_planar"]


@dataclass(frozen=True)
class PlanarOutcome:
    """``runs`` whole-plan runs: ``success`` (a ``Rate`` with its interval), ``step_tried[k]`` and
    ``step_failed[k]`` (runs that reached / failed step k+1), ``seconds``."""

    success: Rate
    step_tried: tuple[int, ...]
    step_failed: tuple[int, ...]
    seconds: float


def run_planar(plan: PlanResult, assembly: Assembly, params: SimParams = DEFAULT_PARAMS,
               trials: int | None = 100, seed: int = 0, carry: bool = True,
               errors: ErrorModel | None = None, mm_per_unit: float = 1.0,
               runner: RolloutRunner | None = None, on_progress=None) -> PlanarOutcome:
    """Run ``plan`` (module doc)."""
    rplan = RolloutPlan(tuple(s.to_operation() for s in plan.steps), params,
                        errors or ErrorModel.zero(), mm_per_unit, carry)
    m = measure(assembly, rplan, runner or InProcess(), seed, rollouts=trials,
                on_progress=on_progress)
    return PlanarOutcome(m.success, m.step_tried, m.step_failed, m.seconds)
