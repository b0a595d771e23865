"""The whole plan in the planar simulator, each step starting where the earlier ones left the parts.

R multiplies per-step success rates, each measured with the fixed parts exactly in their places.
``run_planar(plan, assembly, params, trials, seed)`` measures instead how often the whole plan
succeeds when the noise is carried from step to step: in each of ``trials`` runs, step k is one
trial of the robustness simulator (``rap.sim.simulator``: the same controller, noise ``eta``,
tolerances and time limit as the scores) with its fixed parts where the earlier steps of *this
run* actually left them: a successful step ends within the success tolerance of its goal
(``pos_tol`` of the part's extent, ``angle_tol_rad``), not on it, and that pose (offset and
rotation about the part's centroid) becomes the part's placement from then on. A run fails at
its first failed step (later steps are not tried).

The displaced geometry is rebuilt per step as an ``Assembly`` whose coordinates are the moved
vertices rounded to multiples of ``1 / DENOMINATOR`` (10^-6 of a unit: far below the tolerances;
one common denominator keeps the exact convex decomposition's integers small). Randomness: run
``i`` draws from ``SeedSequence(seed).spawn(trials)[i]``, so a run does not depend on the others.
Returns a ``PlanarOutcome``: successes, per-step reached and failed counts, and the plan success's
Clopper-Pearson interval (``rap.robot.trials``).

Cost: trials x steps single-trial simulations (a few milliseconds each; a 22-step plan, 100 runs,
about 10-30 s on one core).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from rap.assembly import Assembly, Part
from rap.plan.report.result import PlanResult
from rap.robot.trials import Rate, rate
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.sim.simulator import build_scene, run_trials

__all__ = ["PlanarOutcome", "run_planar", "moved_assembly", "DENOMINATOR"]

DENOMINATOR = 10 ** 6


@dataclass(frozen=True)
class PlanarOutcome:
    """``runs`` whole-plan runs: ``success`` (a ``Rate`` with its interval), ``step_tried[k]`` and
    ``step_failed[k]`` (runs that reached / failed step k+1), ``seconds``."""

    success: Rate
    step_tried: tuple[int, ...]
    step_failed: tuple[int, ...]
    seconds: float


def _moved_ring(ring, pose) -> tuple:
    (px, py), (ox, oy), ang = pose
    c, s = math.cos(ang), math.sin(ang)
    out = []
    for x, y in ring:
        dx, dy = float(x) - px, float(y) - py
        out.append((Fraction(round((px + c * dx - s * dy + ox) * DENOMINATOR), DENOMINATOR),
                    Fraction(round((py + s * dx + c * dy + oy) * DENOMINATOR), DENOMINATOR)))
    return tuple(out)


def moved_assembly(assembly: Assembly, poses: dict) -> Assembly:
    """``assembly`` with each part in ``poses`` (``((pivot_x, pivot_y), (offset_x, offset_y),
    angle_rad)``: rotated about the pivot, then translated) moved; the others as they are."""
    parts = []
    for p in assembly.parts:
        pose = poses.get(p.id)
        if pose is None or (pose[1] == (0.0, 0.0) and pose[2] == 0.0):
            parts.append(p)
        else:
            parts.append(Part(p.id, _moved_ring(p.outer, pose),
                              tuple(_moved_ring(h, pose) for h in p.holes)))
    return Assembly(assembly.name, tuple(parts), units=assembly.units)


def _one_step(assembly: Assembly, op, params: SimParams, rng) -> tuple | None:
    """One trial of ``op``: None on failure, else the moving part's final pose."""
    scene = build_scene(assembly, op, params, trials=1)
    info = run_trials(scene, params, rng, record=1, record_every=1)
    if info.outcome[0] != 1:
        return None
    rec, decided = info.recording
    frames = rec[0, :decided[0] + 1]
    ok = frames[~np.isnan(frames[:, 0])]
    x, y, ang = ok[-1]
    off = (np.array([x, y]) - scene.goal) / scene.scale
    pivot = (scene.center[0] + scene.goal[0] / scene.scale,
             scene.center[1] + scene.goal[1] / scene.scale)
    return pivot, (float(off[0]), float(off[1])), float(ang)


def run_planar(plan: PlanResult, assembly: Assembly, params: SimParams = DEFAULT_PARAMS,
               trials: int = 100, seed: int = 0, carry: bool = True) -> PlanarOutcome:
    """Run ``plan`` ``trials`` times (module doc). Steps may move subassemblies (the simulator
    moves them as one body); their parts then share the final pose. ``carry=False`` is the
    control: every step starts with the parts exactly in place, as R assumes (the same runs,
    seeds and stopping rule otherwise)."""
    t0 = time.perf_counter()
    steps = plan.steps
    tried, failed = [0] * len(steps), [0] * len(steps)
    wins = 0
    for child in np.random.SeedSequence(seed).spawn(trials):
        rng = np.random.default_rng(child)
        poses: dict = {}
        ok = True
        for k, s in enumerate(steps):
            tried[k] += 1
            moved = moved_assembly(assembly, poses)
            end = _one_step(moved, s.to_operation(), params, rng)
            if end is None:
                failed[k] += 1
                ok = False
                break
            for pid in s.moving if carry else ():
                old = poses.get(pid)
                poses[pid] = end if old is None else _compose(old, end)
        wins += ok
    return PlanarOutcome(rate(wins, trials), tuple(tried), tuple(failed),
                         time.perf_counter() - t0)


def _compose(first, then):
    """The pose ``then`` applied after ``first`` (a subassembly moved again), as one pose about
    ``then``'s pivot."""
    (p1x, p1y), (o1x, o1y), a1 = first
    (p2x, p2y), (o2x, o2y), a2 = then
    # x -> R2 (R1 (x - p1) + p1 + o1 - p2) + p2 + o2; about pivot p2:
    c1, s1 = math.cos(a1), math.sin(a1)
    # image of p2 under the first pose
    dx, dy = p2x - p1x, p2y - p1y
    q = (p1x + c1 * dx - s1 * dy + o1x, p1y + s1 * dx + c1 * dy + o1y)
    c2, s2 = math.cos(a2), math.sin(a2)
    qx, qy = q[0] - p2x, q[1] - p2y
    return (p2x, p2y), (c2 * qx - s2 * qy + o2x, s2 * qx + c2 * qy + o2y), a1 + a2
