"""Perturbed-start scores: an operation's success with its fixed parts where earlier steps leave
them, the score a step has inside a rollout rather than from the exact placement.

``perturbed_successes(assembly, op, params, errors, mm_per_unit, seed)`` runs ``params.trials``
trials of ``op`` in the robustness simulator (``rap.sim.simulator``), each with

* every fixed part off its place by one draw of the **rest offsets** (``rest_offsets()``: where
  the moving parts of 13,265 succeeded rollout steps came to rest, on the default plans of twelve
  assemblies under the shipped cell's errors, as (distance from the goal / the step's tolerance
  radius, angle); ``rap/data/rest_offsets.json``, written by ``python -m research.perturbed_starts
  offsets``): the distance scaled to that part's tolerance radius (``pos_tol`` of its extent in
  the insertion's frame), a uniform direction, the angle's sign at random;
* the moving parts held off the controlled body by one draw of the cell's ``ErrorModel``;
* the rollouts' rule of success (``rap.execution.rollout``): the body reaches the goal, the
  controller goes on ``SETTLE_S``, the parts rest within the tolerance.

Trial ``t`` draws from ``SeedSequence(seed, spawn_key=(t,))`` alone: the count depends on the
seed (the problem's ``seed(op)``) and the operation only. Each fixed part is drawn on its own
(parts placed together move together in a real run), so a perturbed start is rougher than a
rollout's.

What they are for (``rap.plan.execution``'s perturbed candidate): the best product of perturbed
scores over the AND/OR graph is a plan R does not rank near its top where a tight insertion meets
parts placed loosely before it (a 7-part pegs assembly: R's 974th of 1,142 sequences, measured 2x
R's best; docs/ROBOT.md, "The best of all sequences"). Cost: one operation's labelling (about
0.15 s on a core at 100 trials).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Protocol, Sequence, runtime_checkable

import numpy as np

from rap.assembly import Assembly
from rap.execution.error_model import ErrorModel
from rap.operation import Operation
from rap.sim.params import SimParams

__all__ = ["REST_OFFSETS", "rest_offsets", "perturbed_successes", "perturbed_key",
           "PerturbedRunner"]

REST_OFFSETS = Path(__file__).resolve().parents[1] / "data" / "rest_offsets.json"


@runtime_checkable
class PerturbedRunner(Protocol):
    """Runs ``perturbed_successes(*job)`` for each job (its positional arguments), results in the
    order of ``jobs``: the local simulator's workers do (the operations in parallel)."""

    def run_perturbed(self, jobs: Sequence[tuple]) -> list[int]: ...


@functools.lru_cache(maxsize=4)
def rest_offsets(path: str | Path = REST_OFFSETS) -> np.ndarray:
    """The recorded rest offsets, float64 [N, 2]: (distance / tolerance radius, angle in rad)."""
    return np.array(json.loads(Path(path).read_text())["offsets"], dtype=float)


@functools.lru_cache(maxsize=4)
def _file_hash(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def perturbed_key(key: str, errors: ErrorModel, mm_per_unit: float) -> str:
    """The score cache's key (``rap.plan.scoring.cache``) of an operation's perturbed-start count:
    its exact-start key (``PlanningProblem.key``: geometry, operation, parameters, root seed) with
    what else the count depends on (the error model, the scale, the shipped rest offsets, the
    settle time), so it never meets an exact-start score. O(1) after the offsets' first hash."""
    from rap.execution.rollout import SETTLE_S

    extra = json.dumps([errors.to_dict(), float(mm_per_unit), _file_hash(REST_OFFSETS), SETTLE_S],
                       sort_keys=True)
    return f"{key}:perturbed:{hashlib.sha256(extra.encode()).hexdigest()[:16]}"


def _part_extent(assembly: Assembly, part: str, direction) -> float:
    """The larger side of ``part``'s bounding box in the insertion's frame (assembly units)."""
    from rap.sim.placement import frame_axes

    d, n = frame_axes(direction)
    pts = assembly.part(part).float_outer()
    us = [x * d[0] + y * d[1] for x, y in pts]
    ws = [x * n[0] + y * n[1] for x, y in pts]
    return max(max(us) - min(us), max(ws) - min(ws))


def perturbed_successes(assembly: Assembly, op: Operation, params: SimParams, errors: ErrorModel,
                        mm_per_unit: float, seed: int, offsets: np.ndarray | None = None) -> int:
    """Successes of ``params.trials`` perturbed-start trials of ``op`` (module doc);
    ``offsets``: the rest offsets (None: ``rest_offsets()``)."""
    from rap.execution.rollout import SETTLE_S, part_pose, within_tolerance
    from rap.sim.layouts import TrialLayout
    from rap.sim.shapes import area_centroid, assembly_pieces
    from rap.sim.simulator import build_scene, run_trials

    offsets = rest_offsets() if offsets is None else offsets
    pieces = assembly_pieces(assembly)
    fixed = sorted(op.fixed)  # per part, once: its tolerance radius and its centroid
    radius = {q: params.pos_tol * _part_extent(assembly, q, op.direction) for q in fixed}
    centroid = {q: area_centroid(pieces[q])[1:] for q in fixed}
    layouts, rngs = [], []
    for t in range(params.trials):
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(t,)))
        poses = {}
        for q in fixed:
            frac, ang = offsets[rng.integers(len(offsets))]
            phi = rng.uniform(0.0, 2.0 * math.pi)
            r = frac * radius[q]
            poses[q] = (centroid[q], (r * math.cos(phi), r * math.sin(phi)),
                        float(ang) * (1.0 if rng.random() < 0.5 else -1.0))
        grasp = errors.offsets(rng, op.direction, mm_per_unit)
        layouts.append(TrialLayout(poses, grasp))
        rngs.append(rng)
    p = params if errors.force_noise else replace(params, eta=0.0)
    settle = max(1, int(round(SETTLE_S / (p.dt_s * p.control_substeps))))
    scene = build_scene(assembly, op, p, layouts=layouts)
    info = run_trials(scene, p, None, record=len(layouts), trial_rngs=rngs, settle_steps=settle)
    rec = info.recording[0]
    wins = 0
    for t in range(len(layouts)):
        if info.outcome[t] == 1:
            last = rec[t][~np.isnan(rec[t][:, 0])][-1]
            wins += within_tolerance(part_pose(last, scene, layouts[t].grasp), scene, p)
    return int(wins)
