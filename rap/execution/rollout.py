"""Whole-plan rollouts: each step starts where the earlier steps of the same rollout left the parts,
with the part off its place as the cell's error model says.

R multiplies step scores, each measured with the fixed parts exactly in their places and the part
exactly in the gripper. A rollout executes the whole plan once in the robustness simulator
(``rap.sim.simulator``: the same controller, noise, tolerances and time limit as the scores):

* step k is one trial whose fixed parts lie where this rollout's earlier steps left them
  (``rap.sim.layouts``), and whose moving parts ride off the controlled body by one draw of the
  ``ErrorModel`` (grasp and arm, ``rap.execution.error_model``);
* the step succeeds when the body reaches the goal (the simulator's test); the controller then goes
  on for ``SETTLE_S`` (the arm finishes its motion) and the parts, off the body by their grasp,
  must come to rest within the same tolerance of their goal (``pos_tol`` of the moving extent,
  ``angle_tol_rad``); where they rest becomes their place for the later steps (``carry``);
* a rollout fails at its first failed step; later steps are not tried;
* a **free** step (its moving parts touch no fixed part along the insertion or at the goal,
  exact: ``rap.geometry.ndbg.is_free_operation``, the scorer's rule) is not simulated, as it is
  not scored: its parts land off their goal by the grasp's draw alone, and succeed when that lies
  within the tolerance.

Seeds: rollout ``i``'s step ``k`` draws its error and its noise from
``SeedSequence(root_seed, spawn_key=(i, k))`` alone. Rollouts are run in **chunks** of consecutive
indices (``CHUNK``), each chunk's live rollouts as the trials of one space per step; a chunk is
the unit of parallel work, and because a space's trials are not bit-for-bit independent of each
other (``rap.sim.simulator``), the chunks are fixed by index: a rollout's result depends on the
root seed, its index and the plan, never on the worker, the node or the order.

``carry=False`` with ``ErrorModel.zero()`` is the control: every step starts exactly in place, so
a rollout succeeds with the product of the steps' success rates (R's assumption).

Cost: a chunk is at most ``steps`` spaces of ``CHUNK`` trials: about the cost of labelling
``steps x CHUNK / trials`` operations (a 22-step plan: about 0.5-2 s a chunk on one core).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from rap.assembly import Assembly
from rap.execution.error_model import ErrorModel
from rap.operation import Operation
from rap.sim.layouts import Pose, TrialLayout, compose_poses
from rap.sim.params import SimParams
from rap.sim.simulator import build_scene, run_trials

__all__ = ["RolloutPlan", "ChunkOutcome", "CHUNK", "SETTLE_S", "chunks", "run_chunk", "step_rng",
           "part_pose", "within_tolerance"]

SETTLE_S = 2.0  # a step that succeeds goes on under control this long: where its parts come to rest
CHUNK = 25  # rollouts per chunk: the unit of parallel work (fixed, so results do not depend on it)


@dataclass(frozen=True)
class RolloutPlan:
    """A plan as rollouts run it: its steps in assembly order, the simulator's parameters, the
    cell's errors and the scale that turns them into assembly units."""

    steps: tuple[Operation, ...]
    params: SimParams
    errors: ErrorModel
    mm_per_unit: float
    carry: bool = True

    def __post_init__(self):
        if not self.steps:
            raise ValueError("a rollout needs at least one step")
        if not (self.mm_per_unit > 0 and math.isfinite(self.mm_per_unit)):
            raise ValueError(f"mm_per_unit must be > 0, not {self.mm_per_unit!r}")


@dataclass(frozen=True)
class ChunkOutcome:
    """Rollouts ``first .. first + len(failed_at) - 1``: for each, the 0-based step at which it
    failed, or -1 when every step succeeded; ``seconds`` of work."""

    first: int
    failed_at: tuple[int, ...]
    seconds: float = 0.0


def chunks(start: int, stop: int) -> list[tuple[int, int]]:
    """The chunks ``(first, count)`` that cover rollouts ``start .. stop - 1`` (``start`` a multiple
    of ``CHUNK``)."""
    if start % CHUNK:
        raise ValueError(f"rollouts are measured in chunks of {CHUNK}; start {start} is not one")
    return [(i, min(CHUNK, stop - i)) for i in range(start, stop, CHUNK)]


def step_rng(root_seed: int, index: int, step: int) -> np.random.Generator:
    """The generator of rollout ``index``'s step ``step`` (module doc)."""
    return np.random.default_rng(np.random.SeedSequence(int(root_seed) & (2 ** 63 - 1),
                                                        spawn_key=(int(index), int(step))))


def part_pose(rec_pose, scene, grasp) -> Pose:
    """Where the parts of a decided trial ended (``Pose`` about their goal centroid), from the
    body's recorded pose and the grasp they rode it by."""
    x, y, ang = rec_pose
    pivot = (scene.center[0] + scene.goal[0] / scene.scale,
             scene.center[1] + scene.goal[1] / scene.scale)
    c, s = math.cos(ang), math.sin(ang)
    gx, gy, gang = grasp
    off = ((x - scene.goal[0]) / scene.scale + c * gx - s * gy,
           (y - scene.goal[1]) / scene.scale + s * gx + c * gy)
    return pivot, off, float(ang + gang)


def _free_steps(assembly: Assembly, steps) -> list[bool]:
    from fractions import Fraction

    from rap.geometry.contacts import meeting_pairs
    from rap.geometry.ndbg import is_free_operation, ndbg_of

    ndbg, meeting = ndbg_of(assembly), meeting_pairs(assembly)
    out = []
    for op in steps:
        d = op.exact_direction if op.exact_direction is not None else op.direction
        out.append(is_free_operation(ndbg, meeting, op.moving, op.fixed,
                                     (-Fraction(d[0]), -Fraction(d[1]))))
    return out


def _free_landing(assembly: Assembly, op: Operation, params: SimParams
                  ) -> tuple[tuple[float, float], float]:
    """A free step's pivot (its moving parts' area centroid) and tolerance radius, the same for
    every rollout: computed once a step."""
    from rap.sim.outline import assembly_outlines
    from rap.sim.placement import placement
    from rap.sim.shapes import area_centroid

    pieces = assembly_outlines(assembly, params.shape_tolerance, params.shape_pieces)
    _, cx, cy = area_centroid([pc for i in sorted(op.moving) for pc in pieces[i]])
    radius = params.pos_tol * placement(assembly, op, params.start_gap).moving_extent
    return (cx, cy), radius


def _landed(pivot: tuple[float, float], grasp) -> Pose:
    """A free step's pose: its parts off their goal by the grasp, about ``pivot``."""
    return pivot, (grasp[0], grasp[1]), float(grasp[2])


def within_tolerance(pose: Pose, scene, params: SimParams, radius: float | None = None) -> bool:
    """Whether parts at ``pose`` (``part_pose``) rest within the success tolerance of their goal:
    ``pos_tol`` of the scene's moving extent (or ``radius``, assembly units) and
    ``angle_tol_rad``."""
    (ox, oy), ang = pose[1], pose[2]
    tol = params.pos_tol * scene.moving_extent / scene.scale if radius is None else radius
    ang = (ang + math.pi) % (2 * math.pi) - math.pi
    return ox * ox + oy * oy < tol * tol and abs(ang) < params.angle_tol_rad


def _carry(poses: dict, op: Operation, pose: Pose) -> None:
    """The moving parts of ``op`` now lie at ``pose`` (after where they lay, if they were moved
    before with a subassembly)."""
    for p in op.moving:
        old = poses.get(p)
        poses[p] = pose if old is None else compose_poses(old, pose)


def run_chunk(assembly: Assembly, plan: RolloutPlan, root_seed: int, first: int,
              count: int) -> ChunkOutcome:
    """Rollouts ``first .. first + count - 1`` of ``plan`` (module doc); ``first`` is a chunk's
    start (a multiple of ``CHUNK``) and ``count`` at most ``CHUNK``."""
    if first % CHUNK or not 1 <= count <= CHUNK:
        raise ValueError(f"a chunk is up to {CHUNK} rollouts from a multiple of {CHUNK}")
    t0 = time.perf_counter()
    params = plan.params if plan.errors.force_noise else replace(plan.params, eta=0.0)
    settle = max(1, int(round(SETTLE_S / (params.dt_s * params.control_substeps))))
    poses: list[dict[str, Pose]] = [{} for _ in range(count)]
    failed = [-1] * count
    alive = list(range(count))
    free = _free_steps(assembly, plan.steps)
    for k, op in enumerate(plan.steps):
        if not alive:
            break
        rngs = [step_rng(root_seed, first + j, k) for j in alive]
        grasps = [plan.errors.offsets(r, op.direction, plan.mm_per_unit) for r in rngs]
        if free[k]:
            survivors = []
            pivot, radius = _free_landing(assembly, op, params)
            for j, g in zip(alive, grasps):
                pose = _landed(pivot, g)
                if not within_tolerance(pose, None, params, radius):
                    failed[j] = k
                    continue
                survivors.append(j)
                if plan.carry:
                    _carry(poses[j], op, pose)
            alive = survivors
            continue
        layouts = [TrialLayout({p: poses[j][p] for p in op.moving | op.fixed if p in poses[j]}, g)
                   for j, g in zip(alive, grasps)]
        scene = build_scene(assembly, op, params, layouts=layouts)
        info = run_trials(scene, params, None, record=len(alive), trial_rngs=rngs,
                          settle_steps=settle)
        rec = info.recording[0]
        survivors = []
        for t, j in enumerate(alive):
            pose = None
            if info.outcome[t] == 1:
                last = rec[t][~np.isnan(rec[t][:, 0])][-1]  # at rest: after its settling
                pose = part_pose(last, scene, grasps[t])
            if pose is None or not within_tolerance(pose, scene, params):
                failed[j] = k
                continue
            survivors.append(j)
            if plan.carry:
                _carry(poses[j], op, pose)
        alive = survivors
    return ChunkOutcome(first, tuple(failed), time.perf_counter() - t0)


def run_chunks(assembly: Assembly, plan: RolloutPlan, root_seed: int,
               work: Sequence[tuple[int, int]]) -> list[ChunkOutcome]:
    """``run_chunk`` for each ``(first, count)`` of ``work``, in order (one process)."""
    return [run_chunk(assembly, plan, root_seed, f, c) for f, c in work]
