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
when the time runs out, or earlier when it is hopeless (checked every 8 control steps): farther than
``far_off`` from the path segment, or, when ``stuck_s > 0``, no progress toward the goal for
``stuck_s``. Hopeless rules are part of the outcome's definition; with the defaults (far_off 1.5
world sizes, stuck off) they changed no score on the fixtures. Score = successes / trials.

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

__all__ = ["SimResult", "simulate", "Scene", "build_scene", "run_trials", "RunInfo", "Trajectories"]

_NOISE_CHUNK = 128  # control steps of noise drawn at once: one (chunk, trials) block, fixed order
_SLOW_CHECK = 8  # control steps between checks for hopeless (far off / stuck) trials
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
    mover_ids: list[int]  # pymunk Body.id of each trial's moving body (batch BODY_ID values)
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
    return Scene(space=space, movers=movers, mover_ids=[b.id for b in movers], statics=statics, origins=origins, start=start,
                 goal=goal, direction=d, length=length, mass=m0.mass, moment=m0.moment,
                 scale=scale, center=(cx, cy), pivot_world=goal,
                 moving_extent=pl.moving_extent * scale, start_offset=pl.start_offset)


@dataclass
class RunInfo:
    """What ``run_trials`` did: outcomes per trial (1 success, -1 failure) and its work."""

    outcome: np.ndarray  # int8 [trials]
    body_steps: int  # sum over physics steps of the moving bodies in the space
    steps_run: int  # physics steps taken
    schedule: list  # (physics step, trial indices removed before it)
    recording: tuple | None  # (poses [record, frames, 3], decided frame [record]) or None
    physics_s: float = 0.0  # time inside pymunk (set forces + step), when run with clock=True


def run_trials(scene: Scene, params: SimParams, rng: np.random.Generator,
               record: int = 0, record_every: int = 1, clock: bool = False) -> RunInfo:
    """Run the controller on every trial of ``scene`` (consumed: bodies are removed from it).

    The recording holds, for trials ``0..record-1``, the pose (position of the moving body in the
    trial's frame, angle) every ``record_every`` control steps. ``clock`` measures the time spent
    inside pymunk (the floor of the same run) into ``RunInfo.physics_s``.
    """
    space, n = scene.space, len(scene.movers)
    p = params
    k_sub = p.control_substeps
    dt = p.dt_s
    n_ctrl = p.steps // k_sub
    dx, dy = float(scene.direction[0]), float(scene.direction[1])
    nx, ny = -dy, dx
    L = scene.length
    m, inertia = scene.mass, scene.moment
    tol2 = (p.pos_tol * scene.moving_extent) ** 2
    far2 = (p.far_off * p.world_size) ** 2
    stuck_ctrl = int(round(p.stuck_s / (dt * k_sub))) if p.stuck_s > 0 else 0
    progress = p.stuck_progress * p.world_size
    carrot_step = p.carrot_speed * dt * k_sub
    lead = p.carrot_lead
    eta = p.eta
    kp, kd, amax2 = p.kp, p.kd, p.max_accel ** 2
    alpha_max = p.max_angular_accel
    ang_tol = p.angle_tol_rad

    # One matmul maps the body state [x, y, angle, vx, vy, omega] to the path frame and to the
    # linear part of the controller: Y = state @ M - C (C: per-row offsets of each trial's path).
    # columns: s (along path from its start), w (left of the path), angle,
    #          -kp s - kd v.d,  -kp w - kd v.n,  -kp_angle angle - kd_angle omega
    M = np.zeros((6, 6))
    M[0:2, 0] = (dx, dy)
    M[0:2, 1] = (nx, ny)
    M[2, 2] = 1.0
    M[0:2, 3], M[3:5, 3] = (-kp * dx, -kp * dy), (-kd * dx, -kd * dy)
    M[0:2, 4], M[3:5, 4] = (-kp * nx, -kp * ny), (-kd * nx, -kd * ny)
    M[2, 5], M[5, 5] = -p.kp_angle, -p.kd_angle
    to_world = m * np.array([[dx, dy], [nx, ny]])  # path-frame acceleration -> world force
    flip = np.array([-1.0, 1.0])

    outcome = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 success, -1 failure
    # per-row state (row = position of the body in Chipmunk's body order = trial order at first)
    rows = np.arange(n)
    C = (scene.origins + scene.start) @ M[0:2]
    carrot = np.zeros(n)
    live = np.ones(n, dtype=bool)
    best = np.full(n, np.inf)
    last_improve = np.zeros(n, dtype=np.int64)
    acc = np.zeros((n, 2))

    setbuf = np.zeros((len(space.bodies), 3))
    out = pb.Buffer()
    out.set_float_buf(setbuf)  # not copied: setbuf must stay alive and in place
    getbuf = pb.Buffer()
    chunk = noise = None
    body_steps = 0
    schedule = []
    rec = rec_decided = None
    if record:
        frames = n_ctrl // record_every + 1
        rec = np.full((record, frames, 3), np.nan)
        rec_decided = np.full(record, frames - 1, dtype=np.int64)
    n_removed = 0
    na = n
    c = 0
    t_phys = 0.0
    for c in range(n_ctrl):
        if eta > 0 and c % _NOISE_CHUNK == 0:
            # one block over ALL trials in a fixed order: independent of retirement
            chunk = rng.uniform(-eta, eta, size=(_NOISE_CHUNK, n))
            noise = chunk[:, rows]
        getbuf.clear()
        pb.get_space_bodies(space, _GET, getbuf)
        st = np.frombuffer(getbuf.float_buf(), dtype=np.float64).reshape(-1, 6)[:na]
        Y = st @ M
        Y -= C
        s, w, ang = Y[:, 0], Y[:, 1], Y[:, 2]
        aang = np.abs(ang)
        if aang.max() > math.pi:  # wrap the orientation error to (-pi, pi]
            wrapped = np.remainder(ang + math.pi, 2 * math.pi) - math.pi
            Y[:, 5] += p.kp_angle * (ang - wrapped)
            ang = wrapped
            aang = np.abs(ang)
        if rec is not None and c % record_every == 0:
            sel = rows < record
            f = c // record_every
            rec[rows[sel], f, 0] = scene.start[0] + s[sel] * dx + w[sel] * nx
            rec[rows[sel], f, 1] = scene.start[1] + s[sel] * dy + w[sel] * ny
            rec[rows[sel], f, 2] = st[sel, 2]

        # --- outcomes at this control step --------------------------------------------------
        e = s - L
        succ = ((e * e + w * w) < tol2) & (aang < ang_tol) & live
        decided = succ
        fail = None
        if c % _SLOW_CHECK == 0:  # hopeless trials: far off the path (or stuck, when enabled)
            beyond = np.maximum(np.maximum(-s, e), 0.0)
            fail = ((w * w + beyond * beyond) > far2) & live & ~succ
            if stuck_ctrl:
                dist = np.sqrt(e * e + w * w)
                improved = dist < best - progress
                best = np.where(improved, dist, best)
                last_improve = np.where(improved, c, last_improve)
                fail |= (c - last_improve > stuck_ctrl) & live & ~succ
            decided = succ | fail

        # --- controller (every current row, decided ones included) -------------------------
        carrot = np.minimum(np.minimum(carrot + carrot_step, s + lead), L)
        acc[:na, 0] = Y[:, 3] + kp * carrot
        acc[:na, 1] = Y[:, 4]
        a = acc[:na]
        a2 = a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1]
        if a2.max() > amax2:
            a = a * np.sqrt(np.minimum(amax2 / np.maximum(a2, 1e-300), 1.0))[:, None]
        if eta > 0:  # + u |F| along the normal of F: (ax, ay) + u (-ay, ax)
            a = a + noise[c % _NOISE_CHUNK][:, None] * (a[:, ::-1] * flip)
        ctrl = np.empty((na, 3))
        np.matmul(a, to_world, out=ctrl[:, 0:2])
        np.multiply(np.minimum(np.maximum(Y[:, 5], -alpha_max), alpha_max), inertia, out=ctrl[:, 2])

        if decided.any():
            outcome[rows[succ]] = 1
            if fail is not None:
                outcome[rows[fail]] = -1
            live &= ~decided
            if rec is not None:
                for t in rows[decided]:
                    if t < record:
                        rec_decided[t] = c // record_every
            if p.retire:
                gone = rows[decided]
                for t in gone:
                    mv, fx = scene.movers[t], scene.statics[t]
                    space.remove(mv, *mv.shapes, fx, *fx.shapes)
                n_removed += len(gone)
                schedule.append((c * k_sub, [int(t) for t in gone]))
                if n_removed == n:
                    break
                # rows follow Chipmunk's swap-remove order: read the body ids back
                getbuf.clear()
                pb.get_space_bodies(space, _GET_IDS, getbuf)
                ids = np.frombuffer(getbuf.int_buf(), dtype=np.uintp)
                na = n - n_removed
                old_pos = {scene.mover_ids[t]: j for j, t in enumerate(rows)}
                where = np.array([old_pos[i] for i in ids[:na].tolist()], dtype=np.int64)
                rows, C, carrot, live = rows[where], C[where], carrot[where], live[where]
                best, last_improve, ctrl = best[where], last_improve[where], ctrl[where]
                if noise is not None:
                    noise = chunk[:, rows]
                setbuf = np.zeros((len(ids), 3))
                out.set_float_buf(setbuf)
            elif not live.any():
                break

        setbuf[:na] = ctrl
        if clock:
            t_phys -= time.perf_counter()
        for _ in range(k_sub):
            pb.set_space_bodies(space, _SET, out)
            space.step(dt)
        if clock:
            t_phys += time.perf_counter()
        body_steps += na * k_sub

    outcome[outcome == 0] = -1
    recording = (rec, rec_decided) if rec is not None else None
    return RunInfo(outcome=outcome, body_steps=body_steps, steps_run=(c + 1) * k_sub,
                   schedule=schedule, recording=recording, physics_s=t_phys)


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
