"""Robustness of an assembly operation: success rate of a noisy controlled insertion (pymunk).

Model (paper, section "Physics Simulation"): the fixed subassembly is static; the moving one is a
single rigid dynamic body (all its parts' convex pieces as Chipmunk polygons with radius
``params.poly_radius``, 0 by default, uniform density; a part of more than ``params.shape_pieces``
pieces, a curved part from a drawing, through at most that many, within ``shape_tolerance`` of
it: ``rap.sim.outline``); no gravity. A proportional feedback
controller drives the body along the straight path from the start (``rap.sim.placement``) to the
goal: a translational force ``F = m (kp (c - x) - kd v)`` toward a carrot ``c`` that advances along
the path at ``carrot_speed`` but stays at most ``carrot_lead`` ahead of the body's projection on the
path, and a torque that only corrects the orientation back to the goal angle. Actuation noise: at
every control step a component perpendicular to ``F``, uniform in ``[-eta |F|, eta |F|]``, is added
to ``F``. A trial succeeds when it is within ``pos_tol`` (fraction of the moving subassembly's
extent) and ``angle_tol_rad`` of the goal at some control step before ``time_limit_s``; it fails
when the time runs out, or earlier when it is hopeless (checked every 8 control steps): farther than
``far_off`` from the path segment, or, when ``stuck_s > 0``, no progress toward the goal for
``stuck_s``. Hopeless rules are part of the outcome's definition; with the defaults (far_off 1.5
world sizes, stuck off) they changed no score on the fixtures. Score = successes / trials.

Speed: all trials of one operation share ONE ``pymunk.Space``; each trial has its own moving body
and its own copy of the fixed pieces (on the space's static body), laid out on a grid far apart,
with collision categories (trial index mod 32) so that trials never touch each other. The control
loop is compiled (``rap.sim.kernel``, numba) and calls Chipmunk's step and pymunk's batched
getters/setters directly, returning to Python only when a trial is decided. Decided trials are
removed from the space (``params.retire``). The noise is drawn as one ``(128, trials)`` block per
128 control steps over all trials in a fixed order, and trials never touch each other; but they are
not bit-for-bit independent: the order in which Chipmunk's solver visits one body's contacts follows
its spatial index, which holds every trial's pieces, so a trial touching several pieces at once can
end otherwise in a space of other trials (without retirement; or with only some of the trials: 22
of 90 splits in 2, 3 or 4 parts of 30 grid, hexagon and pentagons operations changed by up to 4
successes). An operation is therefore always simulated whole, in one space: the unit of parallel
work is the operation.

Determinism: the result depends only on (geometry, operation, params, the rng's state).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pymunk
from pymunk._chipmunk import lib as _cp

from rap.assembly import Assembly
from rap.operation import Operation
from rap.sim import kernel
from rap.sim.kernel import new_poly
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.sim.layouts import TrialLayout, posed_points
from rap.sim.placement import placement
from rap.sim.outline import assembly_outlines
from rap.sim.shapes import area_centroid

__all__ = ["SimResult", "simulate", "Scene", "build_scene", "run_trials", "RunInfo", "Trajectories",
           "warm_up"]

_NOISE_CHUNK = 128  # control steps of noise drawn at once: one (chunk, trials) block, fixed order
_SLOW_CHECK = 8  # control steps between checks for hopeless (far off / stuck) trials


@dataclass(frozen=True)
class SimResult:
    successes: int
    trials: int
    score: float
    seconds: float
    outcomes: tuple[int, ...] = field(default=(), repr=False, compare=False)  # per trial 1 / 0
    body_steps: int = field(default=0, repr=False, compare=False)  # sum of active bodies per step


@dataclass
class Trajectories:
    """Poses of a few trials in assembly coordinates: ``poses[k, f] = (x_offset, y_offset, angle)``
    of trial ``k`` at frame ``f`` as a rigid motion of the moving parts about ``pivot``: a moving
    point ``p`` (assembled pose) is drawn at ``pivot + R(angle) (p - pivot) + (x_offset, y_offset)``.
    """

    pivot: tuple[float, float]
    poses: np.ndarray  # float64 [trials, frames, 3]
    outcomes: tuple[int, ...]
    decided_frame: tuple[int, ...]  # frame index at which each trial was decided (or last)
    frame_dt_s: float
    start_offset: tuple[float, float]


@dataclass
class Scene:
    """One operation's space with all trials; world = (assembly - center) * scale."""

    space: pymunk.Space
    movers: list[pymunk.Body]
    mover_ids: list[int]  # pymunk Body.id of each trial's moving body (batch BODY_ID values)
    moving_shapes: list[list]  # per trial: its moving pieces, cpShape* on its moving body
    fixed_shapes: list[list]  # per trial: its fixed pieces, cpShape* on the static body
    origins: np.ndarray  # [trials, 2] world position of each trial's frame
    start: np.ndarray  # [2] start position of the moving body (trial frame)
    goal: np.ndarray  # [2] goal position of the moving body (trial frame)
    direction: np.ndarray  # [2] unit
    length: float  # path length, world units
    mass: float
    moment: float
    scale: float  # world units per assembly unit
    center: tuple[float, float]
    pivot_world: np.ndarray  # [2] moving centroid at the goal (trial frame) = goal
    moving_extent: float  # world units
    start_offset: tuple[float, float]  # assembly units


def build_scene(assembly: Assembly, operation: Operation, params: SimParams,
                trials: int | None = None, *, layouts: Sequence[TrialLayout] | None = None
                ) -> Scene:
    """Build the shared space: ``trials`` moving bodies at the start, each with its static copy.

    The fixed pieces of every trial hang on the space's own static body (translated to the trial's
    origin), so the only bodies the batched getters visit are the moving ones, in trial order.
    ``layouts`` (one per trial; ``trials`` is then their number): trials whose fixed parts lie
    where earlier steps left them and whose moving body holds its parts off their place
    (``rap.sim.layouts``); the start, the path and the goal are the exact assembly's.
    """
    n = len(layouts) if layouts is not None else params.trials if trials is None else trials
    pl = placement(assembly, operation, params.start_gap)
    scale = params.world_size / pl.extent
    cx, cy = pl.center
    pieces = assembly_outlines(assembly, params.shape_tolerance, params.shape_pieces)

    def world(poly):
        return [((x - cx) * scale, (y - cy) * scale) for x, y in poly]

    fixed = [world(pc) for i in sorted(operation.fixed) for pc in pieces[i]]
    moving = [world(pc) for i in sorted(operation.moving) for pc in pieces[i]]
    _, gx, gy = area_centroid(moving)
    moving_local = [[(x - gx, y - gy) for x, y in pc] for pc in moving]
    fixed_of, moving_of = [fixed] * n, [moving_local] * n
    if layouts is not None:
        def posed(ids, lay):
            return [world(posed_points(pc, lay.poses[i]) if i in lay.poses else pc)
                    for i in sorted(ids) for pc in pieces[i]]

        fixed_of = [posed(operation.fixed, lay) for lay in layouts]
        moving_of = [[posed_points([(x - gx, y - gy) for x, y in pc],
                                   ((0.0, 0.0), (lay.grasp[0] * scale, lay.grasp[1] * scale),
                                    lay.grasp[2])) for pc in posed(operation.moving, lay)]
                     for lay in layouts]
    goal = np.array([gx, gy])
    d = np.array(pl.direction, dtype=float)
    length = pl.travel * scale
    start = goal - length * d

    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    space.iterations = params.iterations
    space.collision_slop = params.collision_slop
    spacing = params.trial_spacing * params.world_size
    origins = np.array([[(k % 32) * spacing, (k // 32) * spacing] for k in range(n)], dtype=float)
    movers, moving_shapes, fixed_shapes = [], [], []
    ground_ptr = space.static_body._body
    add_shape, space_ptr = _cp.cpSpaceAddShape, space._space
    # shape properties go straight to Chipmunk (pymunk's property setters call the same functions
    # through a Python layer that costs more than the shape itself; 100 trials x pieces add up)
    set_friction, set_elasticity = _cp.cpShapeSetFriction, _cp.cpShapeSetElasticity
    set_filter, set_density = _cp.cpShapeSetFilter, _cp.cpShapeSetDensity
    for k in range(n):
        filt = pymunk.ShapeFilter(categories=1 << (k % 32), mask=1 << (k % 32))
        body = pymunk.Body()
        shapes = []
        for pc in moving_of[k]:
            c = new_poly(body._body, pc, params.poly_radius)
            set_density(c, params.density)
            set_friction(c, params.friction)
            set_elasticity(c, params.elasticity)
            set_filter(c, filt)
            shapes.append(c)
        body.position = tuple(origins[k] + start)
        body.angle = 0.0
        space.add(body)
        for c in shapes:
            add_shape(space_ptr, c)
        movers.append(body)
        moving_shapes.append(shapes)
        ox, oy = float(origins[k, 0]), float(origins[k, 1])
        sshapes = []
        for pc in fixed_of[k]:
            c = new_poly(ground_ptr, [(x + ox, y + oy) for x, y in pc], params.poly_radius)
            set_friction(c, params.friction)
            set_elasticity(c, params.elasticity)
            set_filter(c, filt)
            sshapes.append(c)
        fixed_shapes.append(sshapes)
    for ss in fixed_shapes:
        for c in ss:
            add_shape(space_ptr, c)
    m0 = movers[0]
    return Scene(space=space, movers=movers, mover_ids=[b.id for b in movers],
                 moving_shapes=moving_shapes, fixed_shapes=fixed_shapes, origins=origins, start=start, goal=goal, direction=d,
                 length=length, mass=m0.mass, moment=m0.moment, scale=scale, center=(cx, cy),
                 pivot_world=goal, moving_extent=pl.moving_extent * scale,
                 start_offset=pl.start_offset)


def remove_trial(scene: Scene, t: int) -> None:
    """Take trial ``t`` (its moving body and its fixed pieces) out of the space."""
    scene.space.remove(scene.movers[t])
    space_ptr = scene.space._space
    for c in (*scene.moving_shapes[t], *scene.fixed_shapes[t]):
        _cp.cpSpaceRemoveShape(space_ptr, c)


@dataclass
class RunInfo:
    """What ``run_trials`` did: outcomes per trial (1 success, -1 failure) and its work."""

    outcome: np.ndarray  # int8 [trials]
    body_steps: int  # sum over physics steps of the moving bodies in the space
    steps_run: int  # physics steps taken
    schedule: list  # (physics step, trial indices removed before it)
    recording: tuple | None  # (poses [record, frames, 3], decided frame [record]) or None


def _constants(scene: Scene, p: SimParams, record_every: int) -> np.ndarray:
    k_sub = p.control_substeps
    values = {
        "dx": float(scene.direction[0]), "dy": float(scene.direction[1]), "length": scene.length,
        "mass": scene.mass, "moment": scene.moment,
        "tol2": (p.pos_tol * scene.moving_extent) ** 2, "far2": (p.far_off * p.world_size) ** 2,
        "stuck_ctrl": int(round(p.stuck_s / (p.dt_s * k_sub))) if p.stuck_s > 0 else 0,
        "progress": p.stuck_progress * p.world_size,
        "carrot_step": p.carrot_speed * p.dt_s * k_sub, "lead": p.carrot_lead, "eta": p.eta,
        "kp": p.kp, "kd": p.kd, "amax2": p.max_accel ** 2, "alpha_max": p.max_angular_accel,
        "ang_tol": p.angle_tol_rad, "kp_angle": p.kp_angle, "kd_angle": p.kd_angle,
        "dt": p.dt_s, "k_sub": k_sub, "slow_check": _SLOW_CHECK, "noise_chunk": _NOISE_CHUNK,
        "record_every": max(1, record_every),
        "start_x": float(scene.start[0]), "start_y": float(scene.start[1]),
    }
    return np.array([float(values[k]) for k in kernel.CONSTANTS])


def run_trials(scene: Scene, params: SimParams, rng: np.random.Generator | None,
               record: int = 0, record_every: int = 1, log: np.ndarray | None = None, *,
               trial_rngs: Sequence[np.random.Generator] | None = None,
               settle_steps: int = 0) -> RunInfo:
    """Run the controller on every trial of ``scene`` (consumed: bodies are removed from it).

    The compiled loop (``rap.sim.kernel.control_steps``) runs until a trial is decided; decided
    trials are then taken out of the space here (``params.retire``) and the loop resumes. The noise
    of control step c is ``chunk[c % 128, trial]`` of the block drawn at ``c - c % 128``: one
    ``(128, trials)`` block per 128 steps over all trials in a fixed order, whatever was retired.
    The recording holds, for trials ``0..record-1``, the pose (position of the moving body in the
    trial's frame, angle) every ``record_every`` control steps. ``log`` (float64 [control steps,
    trials + 1, 3], zeros) receives the commands applied at each step, for benchmarks' replays.
    ``trial_rngs`` (one per trial, instead of ``rng``): trial t's noise column comes from its own
    generator, so it does not depend on the other trials' (whole-plan rollouts, each seeded).
    ``settle_steps`` > 0: a trial that succeeds stays in the space, under control and without
    noise (the arm holds its goal), for that many control steps more (its outcome is decided; its
    recording goes on): where a rollout's part comes to rest, not where it first came within the
    tolerance.
    """
    space, n = scene.space, len(scene.movers)
    p = params
    k_sub = p.control_substeps
    n_ctrl = p.steps // k_sub
    api = kernel.ChipmunkApi(space, n + 1)  # the movers, then the static body (its row stays 0)
    if api.body_ids()[:n].tolist() != scene.mover_ids:
        raise RuntimeError("pymunk does not iterate the moving bodies first, in trial order")
    id_order = np.argsort(np.array(scene.mover_ids, dtype=np.uintp), kind="stable")
    sorted_ids = np.array(scene.mover_ids, dtype=np.uintp)[id_order]
    id_to_trial = id_order.astype(np.int64)
    row_of_trial = np.zeros(n, dtype=np.int64)
    K = _constants(scene, p, record_every)
    rows = np.arange(n, dtype=np.int64)
    ox = scene.origins[:, 0] + scene.start[0]
    oy = scene.origins[:, 1] + scene.start[1]
    carrot = np.zeros(n)
    best = np.full(n, np.inf)
    last_improve = np.zeros(n, dtype=np.int64)
    live = np.ones(n, dtype=np.uint8)
    decided = np.zeros(n, dtype=np.uint8)
    outcome = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 success, -1 failure
    chunk = np.zeros((1, n))
    if record:
        frames = n_ctrl // max(1, record_every) + 1
        rec = np.full((record, frames, 3), np.nan)
        rec_decided = np.full(record, frames - 1, dtype=np.int64)
    else:
        rec = np.zeros((0, 1, 3))
        rec_decided = None
    log_arr = np.zeros((0, n + 1, 3)) if log is None else log
    body_steps = 0
    schedule = []
    n_removed = 0
    c = 0
    settle_at: dict[int, int] = {}  # succeeded trial -> control step at which it leaves
    while c < n_ctrl:
        if p.eta > 0 and c % _NOISE_CHUNK == 0:
            chunk = (rng.uniform(-p.eta, p.eta, size=(_NOISE_CHUNK, n)) if trial_rngs is None
                     else np.column_stack([r.uniform(-p.eta, p.eta, _NOISE_CHUNK)
                                           for r in trial_rngs]))
            if settle_at:
                chunk[:, list(settle_at)] = 0.0
        c_end = min([n_ctrl, (c // _NOISE_CHUNK + 1) * _NOISE_CHUNK, *settle_at.values()])
        status, bs = kernel.RAN_OUT, 0
        if c_end > c:
            status, c, bs = kernel.control_steps(api.ptrs, K, c, c_end, api.gnum, api.get,
                                                 api.snum, api.sarr, ox, oy, carrot, best,
                                                 last_improve, live, rows, chunk, rec, decided,
                                                 log_arr)
        body_steps += bs
        due = [t for t, at in settle_at.items() if at <= c]
        if status != kernel.DECIDED and not due:
            continue
        gone = due
        for t in due:
            del settle_at[t]
        if status == kernel.DECIDED:
            hit = np.flatnonzero(decided[:len(rows)])
            succ, fail = rows[hit[decided[hit] == 1]], rows[hit[decided[hit] == 2]]
            outcome[succ], outcome[fail] = 1, -1
            live[hit] = 0
            decided[hit] = 0
            if rec_decided is not None:
                for t in rows[hit]:
                    if t < record:
                        rec_decided[t] = c // max(1, record_every)
            settle_at.update((int(t), c + settle_steps) for t in succ if settle_steps > 0)
            if settle_at and p.eta > 0:
                chunk[:, list(settle_at)] = 0.0  # settling: the arm holds its goal, no noise
            gone = gone + [int(t) for t in (fail if settle_steps > 0 else rows[hit])]
        if p.retire and gone:
            for t in gone:
                remove_trial(scene, int(t))
            n_removed += len(gone)
            schedule.append((c * k_sub, [int(t) for t in gone]))
            if n_removed == n:
                break
            # rows follow Chipmunk's swap-remove order: read the body ids back
            trial = id_to_trial[np.searchsorted(sorted_ids, api.body_ids()[:n - n_removed])]
            row_of_trial[rows] = np.arange(len(rows))
            where = row_of_trial[trial]
            rows, ox, oy, carrot = rows[where], ox[where], oy[where], carrot[where]
            best, last_improve, live = best[where], last_improve[where], live[where]
            api.sarr[:len(where)] = api.sarr[where]
            api.sarr[len(where):] = 0.0
            decided = np.zeros(len(where), dtype=np.uint8)
        elif not p.retire and not live.any() and not settle_at:
            break
        if status != kernel.DECIDED:  # a settled trial left before step c's commands
            continue
        if log is not None:
            log[c] = api.sarr
        kernel.apply_and_step(api.ptrs, api.snum, k_sub, p.dt_s)
        body_steps += len(rows) * k_sub
        c += 1
    outcome[outcome == 0] = -1
    recording = (rec, rec_decided) if record else None
    return RunInfo(outcome=outcome, body_steps=body_steps, steps_run=c * k_sub,
                   schedule=schedule, recording=recording)


def simulate(assembly: Assembly, operation: Operation, params: SimParams | None = None,
             rng: np.random.Generator | None = None) -> SimResult:
    """Score ``operation`` with ``params.trials`` noisy trials; deterministic given ``rng``'s state.

    ``rng`` is required (a ``np.random.Generator``; derive it with ``rap.seeds.derive_rng``).
    Cost: O(trials x steps) body-steps at most; decided trials leave the space early.
    """
    if rng is None:
        raise TypeError("simulate needs rng=np.random.Generator (see rap.seeds.derive_rng)")
    p = params if params is not None else DEFAULT_PARAMS
    t0 = time.perf_counter()
    scene = build_scene(assembly, operation, p)
    info = run_trials(scene, p, rng)
    outcome = info.outcome
    succ = int((outcome == 1).sum())
    return SimResult(successes=succ, trials=p.trials, score=succ / p.trials,
                     seconds=time.perf_counter() - t0,
                     outcomes=tuple(int(o == 1) for o in outcome), body_steps=info.body_steps)


def warm_up() -> float:
    """Load (or compile) the compiled control loop once, on a two-square operation with two
    trials, so that a worker's first real operation is not slowed by it. Returns the seconds."""
    from fractions import Fraction

    from rap.assembly import Part

    t0 = time.perf_counter()
    sq = [(0, 0), (10, 0), (10, 10), (0, 10)]
    a = Assembly("warm-up", (Part("a", tuple((Fraction(x), Fraction(y)) for x, y in sq)),
                             Part("b", tuple((Fraction(x + 10), Fraction(y)) for x, y in sq))))
    op = Operation(frozenset({"b"}), frozenset({"a"}), (-1.0, 0.0))
    simulate(a, op, DEFAULT_PARAMS.with_(trials=2), np.random.default_rng(0))
    return time.perf_counter() - t0
