"""A step's tolerance: the largest position error across the insertion that costs it at most a
tenth of its success (simulated).

``tolerance(assembly, operation, params, mm_per_unit, root_seed)`` runs the step's trials with
the part held off the controlled body by ``+e`` and ``-e`` across the insertion (the grasp of
``rap.sim.layouts``; ``TRIALS_PER_SIDE`` trials each side, each with its own generator from the
root seed, the operation and ``e``), for ``e`` on the grid ``GRID_MM``, and returns the largest
``e`` of the grid at which the step's success is not shown to fall below ``LEVEL`` (0.9) of what
it succeeds in with no error (the same number of trials at ``e = 0``): a probe fails when the
upper end of its 95% Clopper-Pearson interval lies below that (a few unlucky trials at a small
error do not end the search). Relative, not absolute: under the
simulator's noise most steps succeed less than 90% of the time even exactly held, and the question
a cell asks is how much error a step absorbs. The grid is searched by bisection (success falls as
the error grows): about four probes of ``2 x TRIALS_PER_SIDE`` trials. A value is a lower bound at
the grid's resolution; 0 when even the smallest error costs more than a tenth, or the step never
succeeds.

When nothing lies across the insertion at the goal (``rap.execution.clearance`` says None), or the
step is free (it touches nothing along the insertion or at the goal), a part off by ``e`` lands
off by ``e``: the tolerance is the simulator's success radius (``pos_tol`` of the moving parts'
extent), without simulation (``across_free``).

A probe's trials fail once stuck for ``STUCK_S`` (``SimParams.stuck_s``), where a score's run to
the time limit: most of a probe's cost is the trials an error jams. Cost: about ``6 x 2 x
TRIALS_PER_SIDE`` single trials (about two operations' labelling).
"""

from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

from dataclasses import replace

import numpy as np

from rap.assembly import Assembly
from rap.stats import clopper_pearson
from rap.operation import Operation
from rap.sim.layouts import TrialLayout
from rap.sim.params import SimParams
from rap.sim.placement import placement
from rap.sim.simulator import build_scene, run_trials

__all__ = ["tolerance", "GRID_MM", "LEVEL", "TRIALS_PER_SIDE", "success_radius_mm",
           "ToleranceRunner"]

GRID_MM = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 7.5, 10.0)
LEVEL = 0.9
TRIALS_PER_SIDE = 20
STUCK_S = 1.5  # a probe's trial fails once it has made no progress for this long (the simulator's
# ``stuck_s`` rule, off for scores): an error that jams a part costs 1.5 s, not the time limit


@runtime_checkable
class ToleranceRunner(Protocol):
    """Runs ``tolerance(*job)`` for each job (each the positional arguments of ``tolerance``),
    results in the order of ``jobs``: the local simulator's workers do (the steps in parallel)."""

    def run_tolerances(self, jobs: Sequence[tuple]) -> list[float]: ...


def success_radius_mm(assembly: Assembly, operation: Operation, params: SimParams,
                      mm_per_unit: float) -> float:
    """The simulator's success radius for this step, in mm."""
    pl = placement(assembly, operation, params.start_gap)
    return params.pos_tol * pl.moving_extent * mm_per_unit


def _successes(assembly, operation, params, mm_per_unit, e_mm: float, seed_key) -> int:
    dx, dy = operation.direction
    e = e_mm / mm_per_unit
    layouts = [TrialLayout({}, (s * -dy * e, s * dx * e, 0.0))
               for s in (1.0, -1.0) for _ in range(TRIALS_PER_SIDE)]
    rngs = [np.random.default_rng(np.random.SeedSequence(seed_key, spawn_key=(t,)))
            for t in range(len(layouts))]
    probe = replace(params, stuck_s=STUCK_S) if params.stuck_s == 0 else params
    scene = build_scene(assembly, operation, probe, layouts=layouts)
    info = run_trials(scene, probe, None, trial_rngs=rngs)
    return int((info.outcome == 1).sum())


def tolerance(assembly: Assembly, operation: Operation, params: SimParams, mm_per_unit: float,
              root_seed: int, key: str = "", across_free: bool = False) -> float:
    """The step's tolerance in mm (module doc). ``key``: the operation's content key (the seeds'
    source beside the root seed); ``across_free``: nothing lies across at the goal (no
    simulation)."""
    radius = success_radius_mm(assembly, operation, params, mm_per_unit)
    if across_free:
        return radius
    grid = [g for g in GRID_MM if g < 2 * radius] or [GRID_MM[0]]
    base = [int(root_seed) & (2 ** 63 - 1), *key.encode()[:32]]
    exact = _successes(assembly, operation, params, mm_per_unit, 0.0, [*base, len(GRID_MM)])
    if exact == 0:
        return 0.0
    lo, hi = -1, len(grid)  # grid[lo] passes (lo -1: none known), grid[hi] fails
    while hi - lo > 1:
        mid = (lo + hi) // 2
        k = _successes(assembly, operation, params, mm_per_unit, grid[mid], [*base, mid])
        if clopper_pearson(k, 2 * TRIALS_PER_SIDE)[1] >= LEVEL * exact / (2 * TRIALS_PER_SIDE):
            lo = mid
        else:
            hi = mid
    return grid[lo] if lo >= 0 else 0.0
