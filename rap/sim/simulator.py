"""Robustness of an assembly operation: success rate of a noisy controlled insertion (pymunk).

Model (paper, section "Physics Simulation"): the fixed subassembly is static; the moving one is a
single rigid dynamic body (all its parts' convex pieces as ``pymunk.Poly`` with radius
``params.poly_radius``, 0 by default, uniform density); no gravity. A proportional feedback
controller drives the body along the straight path from the start (``rap.sim.placement``) to the
goal: a translational force ``F = m (kp (c - x) - kd v)`` toward a carrot ``c`` that advances along
the path at ``carrot_speed`` but stays at most ``carrot_lead`` ahead of the body's projection on the
path, and a torque that only corrects the orientation back to the goal angle. Actuation noise: at
every control step a component perpendicular to ``F``, uniform in ``[-eta |F|, eta |F|]``, is added
to ``F``. A trial succeeds when it is within ``pos_tol`` (fraction of the moving subassembly's
extent) and ``angle_tol_rad`` of the goal at some control step before ``time_limit_s``; it fails
when the time runs out, or earlier when it is hopeless: farther than ``far_off`` from the path, or
no progress toward the goal for ``stuck_s``. Score = successes / trials.

Speed: all trials of one operation share ONE ``pymunk.Space``; each trial has its own static body
holding a copy of the fixed pieces and its own moving body, laid out on a grid far apart, and
collision categories (trial index mod 32) so that trials never touch each other. The controller
runs for all trials at once in numpy through ``pymunk.batch``. Decided trials are removed from the
space (``params.retire``); this never changes an outcome, because the noise is drawn as one
``(steps, trials)`` block per chunk of steps over all trials in a fixed order and the trials do
not interact.

Determinism: the result depends only on (geometry, operation, params, the rng's state).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pymunk
import pymunk.batch as pb

from rap.assembly import Assembly
from rap.operation import Operation
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.sim.placement import placement
from rap.sim.shapes import assembly_pieces

__all__ = ["SimResult", "simulate", "Scene", "build_scene", "run_trials", "Trajectories"]

_NOISE_CHUNK = 128  # steps of noise drawn at once: one (chunk, trials) block, fixed order
_GET = (pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY
        | pb.BodyFields.ANGULAR_VELOCITY)
_GET_IDS = pb.BodyFields.BODY_ID | pb.BodyFields.POSITION
_SET = pb.BodyFields.FORCE | pb.BodyFields.TORQUE


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
    statics: list[pymunk.Body]
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


def _area_centroid(pieces) -> tuple[float, float, float]:
    a_sum = cx = cy = 0.0
    for poly in pieces:
        x0, y0 = poly[0]
        for (x1, y1), (x2, y2) in zip(poly[1:-1], poly[2:]):
            a = ((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)) / 2
            a_sum += a
            cx += a * (x0 + x1 + x2) / 3
            cy += a * (y0 + y1 + y2) / 3
    return a_sum, cx / a_sum, cy / a_sum


def build_scene(assembly: Assembly, operation: Operation, params: SimParams,
                trials: int | None = None) -> Scene:
    """Build the shared space: ``trials`` moving bodies at the start, each with its static copy."""
    n = params.trials if trials is None else trials
    pl = placement(assembly, operation, params.start_gap)
    scale = params.world_size / pl.extent
    cx, cy = pl.center
    pieces = assembly_pieces(assembly)

    def world(poly):
        return [((x - cx) * scale, (y - cy) * scale) for x, y in poly]

    fixed = [world(pc) for i in sorted(operation.fixed) for pc in pieces[i]]
    moving = [world(pc) for i in sorted(operation.moving) for pc in pieces[i]]
    _, gx, gy = _area_centroid(moving)
    moving_local = [[(x - gx, y - gy) for x, y in pc] for pc in moving]
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
    movers, statics, shapes_fixed = [], [], []
    for k in range(n):
        filt = pymunk.ShapeFilter(categories=1 << (k % 32), mask=1 << (k % 32))
        body = pymunk.Body()
        shapes = []
        for pc in moving_local:
            sh = pymunk.Poly(body, pc, radius=params.poly_radius)
            sh.density = params.density
            sh.friction = params.friction
            sh.elasticity = params.elasticity
            sh.filter = filt
            shapes.append(sh)
        body.position = tuple(origins[k] + start)
        body.angle = 0.0
        space.add(body, *shapes)
        movers.append(body)
        st = pymunk.Body(body_type=pymunk.Body.STATIC)
        st.position = tuple(origins[k])
        sshapes = []
        for pc in fixed:
            sh = pymunk.Poly(st, pc, radius=params.poly_radius)
            sh.friction = params.friction
            sh.elasticity = params.elasticity
            sh.filter = filt
            sshapes.append(sh)
        statics.append(st)
        shapes_fixed.append(sshapes)
    for st, ss in zip(statics, shapes_fixed):  # statics after all movers: rows 0..n-1 = trials
        space.add(st, *ss)
    m0 = movers[0]
    return Scene(space=space, movers=movers, statics=statics, origins=origins, start=start,
                 goal=goal, direction=d, length=length, mass=m0.mass, moment=m0.moment,
                 scale=scale, center=(cx, cy), pivot_world=goal,
                 moving_extent=pl.moving_extent * scale, start_offset=pl.start_offset)


def run_trials(scene: Scene, params: SimParams, rng: np.random.Generator,
               record: int = 0, record_every: int = 1):
    """Run the controller on every trial of ``scene``; returns (outcomes, body_steps, recording).

    ``recording`` is ``None`` or ``(poses[record, frames, 3], decided_step[record])`` in world
    coordinates of each trial's frame (position of the moving body, angle).
    """
    space, n = scene.space, len(scene.movers)
    p = params
    dt, steps = p.dt_s, p.steps
    d = scene.direction
    L = scene.length
    m, inertia = scene.mass, scene.moment
    pos_tol = p.pos_tol * scene.moving_extent
    far = p.far_off * p.world_size
    stuck_steps = int(round(p.stuck_s / dt))
    progress = p.stuck_progress * p.world_size
    base = scene.origins + scene.start  # path start of every trial (world)
    goal_rel = L * d  # goal relative to the path start

    outcome = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 success, -1 failure
    carrot = np.zeros(n)
    best = np.full(n, np.inf)
    last_improve = np.zeros(n, dtype=np.int64)
    rows = np.arange(n)  # trial index of each dynamic body row
    n_bodies = len(space.bodies)
    setbuf = np.zeros((n_bodies, 3))
    out = pb.Buffer()
    out.set_float_buf(setbuf)  # not copied: setbuf must stay alive and in place
    getbuf = pb.Buffer()
    noise = None
    body_steps = 0
    rec = None
    if record:
        frames = steps // record_every + 1
        rec = np.full((record, frames, 3), np.nan)
        rec_decided = np.full(record, frames - 1, dtype=np.int64)
    removed = set()

    for step in range(steps):
        if p.eta > 0 and step % _NOISE_CHUNK == 0:
            noise = rng.uniform(-p.eta, p.eta, size=(_NOISE_CHUNK, n))
        getbuf.clear()
        pb.get_space_bodies(space, _GET, getbuf)
        na = len(rows)
        st = np.frombuffer(getbuf.float_buf(), dtype=np.float64).reshape(-1, 6)[:na]
        x = st[:, 0:2] - base[rows]
        ang = np.remainder(st[:, 2] + math.pi, 2 * math.pi) - math.pi
        vel = st[:, 3:5]

        if rec is not None and step % record_every == 0:
            sel = rows < record
            f = step // record_every
            rec[rows[sel], f, 0:2] = x[sel] + scene.start
            rec[rows[sel], f, 2] = st[sel, 2]

        # --- outcomes at this control step ---------------------------------------------
        s_proj = x @ d
        e_goal = goal_rel - x
        dist = np.sqrt(np.einsum("ij,ij->i", e_goal, e_goal))
        live = outcome[rows] == 0
        succ = live & (dist < pos_tol) & (np.abs(ang) < p.angle_tol_rad)
        sc = np.clip(s_proj, 0.0, L)
        off = x - sc[:, None] * d
        off_d = np.sqrt(np.einsum("ij,ij->i", off, off))
        r = rows
        improved = dist < best[r] - progress
        best[r] = np.where(improved, dist, best[r])
        last_improve[r] = np.where(improved, step, last_improve[r])
        fail = live & ~succ & ((off_d > far) | (step - last_improve[r] > stuck_steps))
        # --- controller (for every current row, decided ones included) ------------------
        carrot[r] = np.minimum(np.minimum(carrot[r] + p.carrot_speed * dt, s_proj + p.carrot_lead), L)
        acc = p.kp * (carrot[r][:, None] * d - x) - p.kd * vel
        amag = np.sqrt(np.einsum("ij,ij->i", acc, acc))
        over = amag > p.max_accel
        if over.any():
            acc[over] *= (p.max_accel / amag[over])[:, None]
        ctrl = np.empty((na, 3))
        ctrl[:, 0:2] = acc
        ctrl[:, 0:2] *= m
        if p.eta > 0:
            u = noise[step % _NOISE_CHUNK, r]
            ctrl[:, 0] -= u * acc[:, 1] * m
            ctrl[:, 1] += u * acc[:, 0] * m
        ctrl[:, 2] = np.clip(-p.kp_angle * ang - p.kd_angle * st[:, 5],
                             -p.max_angular_accel, p.max_angular_accel) * inertia

        if succ.any() or fail.any():
            outcome[r[succ]] = 1
            outcome[r[fail]] = -1
            decided = r[succ | fail]
            if rec is not None:
                for k in decided[decided < record]:
                    rec_decided[k] = step // record_every
            if p.retire:
                for k in decided:
                    removed.add(int(k))
                    space.remove(scene.movers[k], *scene.movers[k].shapes,
                                 scene.statics[k], *scene.statics[k].shapes)
                if len(removed) == n:
                    break
                # rows follow Chipmunk's swap-remove order: read the body ids back
                getbuf.clear()
                pb.get_space_bodies(space, _GET_IDS, getbuf)
                ids = np.frombuffer(getbuf.int_buf(), dtype=np.uintp)
                old_pos = {scene.movers[k].id: j for j, k in enumerate(r)}
                na = n - len(removed)
                where = np.array([old_pos[i] for i in ids[:na]], dtype=np.int64)
                rows = r[where]
                ctrl = ctrl[where]
                setbuf = np.zeros((len(ids), 3))
                out.set_float_buf(setbuf)
            elif (outcome != 0).all():
                break

        setbuf[:na] = ctrl
        pb.set_space_bodies(space, _SET, out)
        space.step(dt)
        body_steps += na

    recording = (rec, rec_decided) if rec is not None else None
    return outcome, body_steps, recording


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
    outcome, body_steps, _ = run_trials(scene, p, rng)
    succ = int((outcome == 1).sum())
    return SimResult(successes=succ, trials=p.trials, score=succ / p.trials,
                     seconds=time.perf_counter() - t0,
                     outcomes=tuple(int(o == 1) for o in outcome), body_steps=body_steps)
