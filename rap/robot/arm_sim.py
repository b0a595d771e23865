"""The program run on the arm in pybullet: extruded prisms with friction, noise along the insertion.

``run_arm(program, assembly, trials, seed)`` executes ``program`` (``rap.robot.program``) ``trials``
times in a pybullet world (DIRECT mode, no window) holding the cell's arm, the table and the
parts, and reports per step how often it was reached, inserted or jammed, and the plan's success
(``rap.stats.Rate``). ``ArmSimParams`` holds every constant.

Model.

* **Parts**: each part's convex pieces (``rap.sim.shapes.assembly_pieces``) extruded by
  ``thickness_m`` into convex prisms (pybullet meshes), one multibody a part, density
  ``density_kg_m3``, Coulomb friction ``friction`` (the planner's ``SimParams.friction``), each
  piece shrunk by ``inset_m`` so that parts that touch when assembled are not pressed together.
  The fixture is static; placed parts are dynamic and stay where the physics leaves them, so a
  later step meets the earlier ones as they actually are (``displaced``: the trials in which an
  earlier placed part lay off its goal once a step had settled).
* **Arm, kinematic**: the cell's arm (the Panda's URDF, or a UR built from its DH rows,
  ``rap.robot.arms.ur_model``); the joints are set (``resetJointState``) along the IK path
  (the Panda's ``rap.robot.kinematics.IkSolver``, warm-started; a UR's analytic solution on the
  branch its check keeps) rather than torque-controlled: the arm goes
  where the program says, as a position-controlled industrial arm does, and what is measured is
  the part. Free-space moves (pick, lift, transit) take no physics time: the part is carried
  with the TCP; the arm is checked there for contact with the placed parts (``arm_contacts``).
* **Grip and insertion**: from the approach on, the part hangs on the TCP by a fixed constraint
  of strength ``hold_force_n`` (the suction cup's hold), the TCP moves at ``insertion_speed_m_s``
  from approach to start to goal with physics at ``dt_s``, and the planner's actuation noise acts
  on the part perpendicular to the insertion: a force uniform in ``[-eta, eta] x m x
  noise_accel_m_s2`` (g) per step (``SimParams.eta``), in the assembly's plane. The IK is solved
  every ``ik_every`` steps (2-3 mm of path at most) and the joints interpolated between. At the
  goal the part is given
  ``settle_s`` to come to rest, judged (**inserted** when within ``pos_tol`` of its extent, as
  the planner's success, and ``angle_tol_rad`` of its goal; else **jammed**), released, and the
  parts settle for ``settle_s`` under gravity.
* **Errors** (``errors``, an ``ErrorModel``: none by default; ``execute`` passes the cell's
  ``[errors]``, ``--grasp-error-mm`` its shorthand): where the cup took the part in the tray is
  off across and along the insertion, and the arm lands off by its repeatability, drawn per step
  by ``ErrorModel.offsets`` (the planar rollouts' draw, ``rap.execution``): a position-controlled
  arm's error, which the force noise does not model. The grasp's angle is drawn but not applied
  here (the cup holds the part square).
* **Plan success**: every step inserted and, at the end, every part within the tolerance of its
  assembled place (nothing toppled by a later step).

Randomness: trial ``i`` draws from ``SeedSequence(seed).spawn(trials)[i]``. Frames for a GIF
(``rap.robot.gif``) are recorded in trial 0 when ``frames`` is given. Cost: one IK solve and one
physics step per ``dt_s`` of insertion (about 0.3 ms); a 3-step stack about 0.5 s a trial.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from rap.assembly import Assembly
from rap.execution.error_model import ErrorModel
from rap.robot.arm import set_joints
from rap.robot.arms.ur_model import solver_for
from rap.robot.program import Program
from rap.stats import Rate, rate
from rap.sim.params import DEFAULT_PARAMS
from rap.sim.shapes import assembly_pieces, shrunk_piece

__all__ = ["ArmSimParams", "StepCounts", "ArmOutcome", "run_arm", "DEFAULT_ARM_SIM"]


@dataclass(frozen=True)
class ArmSimParams:
    dt_s: float = 1.0 / 240.0
    density_kg_m3: float = 700.0  # wood
    friction: float = DEFAULT_PARAMS.friction
    inset_m: float = 2e-4
    collision_margin_m: float = 1e-4
    hold_force_n: float = 20.0
    eta: float = DEFAULT_PARAMS.eta
    pos_tol: float = DEFAULT_PARAMS.pos_tol  # fraction of the part's extent
    angle_tol_rad: float = DEFAULT_PARAMS.angle_tol_rad
    settle_s: float = 0.25
    ik_every: int = 8  # physics steps between IK solves along the insertion (joints interpolated)
    noise_accel_m_s2: float = 9.81  # the noise's scale: eta x m x this
    errors: ErrorModel = field(default_factory=ErrorModel.zero)  # module doc, "Errors"
    solver_iterations: int = 50


DEFAULT_ARM_SIM = ArmSimParams()


@dataclass
class StepCounts:
    reached: int = 0
    inserted: int = 0
    jammed: int = 0
    arm_contacts: int = 0  # trials in which the arm touched a placed part during this step
    displaced: int = 0  # trials in which an earlier placed part lay off its goal after this step


@dataclass(frozen=True)
class ArmOutcome:
    success: Rate
    steps: tuple[StepCounts, ...]
    seconds: float
    frames: list = field(default_factory=list, repr=False)


def _prism(world, poly_m, depth_lo, depth_hi, frame, ref):
    """Vertices (relative to ``ref``) of a convex piece extruded between two depths."""
    verts = [frame.point(p, d) - ref for d in (depth_lo, depth_hi) for p in poly_m]
    return [list(map(float, v)) for v in verts]


def _faces(n):
    idx = []
    for i in range(1, n - 1):
        idx += [0, i, i + 1, n, n + i + 1, n + i]
    for i in range(n):
        j = (i + 1) % n
        idx += [i, j, n + j, i, n + j, n + i]
    return idx + idx[::-1]  # both windings: seen from either side


class _Scene:
    """One trial's world: the arm, the table, every part at its assembled place."""

    def __init__(self, program: Program, assembly: Assembly, p: ArmSimParams, make_solver):
        from rap.robot.arm import open_world

        self.p, self.program, fr = p, program, program.frame
        self.world = w = open_world()
        w.setPhysicsEngineParameter(fixedTimeStep=p.dt_s, numSolverIterations=p.solver_iterations)
        self.ik = make_solver(w)
        plane = w.createCollisionShape(w.GEOM_PLANE)
        self.table = w.createMultiBody(0, plane, basePosition=[0, 0, fr.table_z])
        w.changeDynamics(self.table, -1, lateralFriction=p.friction)
        pieces = assembly_pieces(assembly)
        lo, hi = ((-fr.thickness_m / 2, fr.thickness_m / 2) if fr.plane == "vertical"
                  else (0.0, fr.thickness_m))
        inset = p.inset_m / fr.scale_m
        self.body, self.ref, self.extent_m = {}, {}, {}
        colours = [(0.85, 0.55, 0.3, 1), (0.7, 0.4, 0.25, 1), (0.9, 0.7, 0.45, 1)]
        for k, pid in enumerate(assembly.ids):
            polys = [[(float(x), float(y)) for x, y in pc] for pc in pieces[pid]]
            pts = np.array([xy for pc in polys for xy in pc])
            ref = fr.point(pts.mean(axis=0), (lo + hi) / 2)
            ext = pts.max(axis=0) - pts.min(axis=0)
            self.extent_m[pid] = float(max(ext)) * fr.scale_m
            shapes, visuals, masses = [], [], []
            rgba = (0.45, 0.45, 0.5, 1) if pid == program.fixture else colours[k % 3]
            for pc in polys:
                v = _prism(w, shrunk_piece(pc, inset), lo, hi, fr, ref)
                shape = w.createCollisionShape(w.GEOM_MESH, vertices=v)
                # the margin belongs to the shape, and changeDynamics sets it only through a
                # body's base: a static holder far below the table sets it for the links too
                holder = w.createMultiBody(0, shape, basePosition=[0, 0, -100.0])
                w.changeDynamics(holder, -1, collisionMargin=p.collision_margin_m)
                shapes.append(shape)
                visuals.append(w.createVisualShape(w.GEOM_MESH, vertices=v, indices=_faces(len(pc)),
                                                   rgbaColor=rgba))
                area = abs(sum(x1 * y2 - x2 * y1 for (x1, y1), (x2, y2)
                               in zip(pc, pc[1:] + pc[:1]))) / 2 * fr.scale_m ** 2
                masses.append(0.0 if pid == program.fixture else
                              area * fr.thickness_m * p.density_kg_m3)
            n = len(shapes) - 1
            b = w.createMultiBody(
                masses[0], shapes[0], visuals[0], basePosition=list(map(float, ref)),
                linkMasses=masses[1:], linkCollisionShapeIndices=shapes[1:],
                linkVisualShapeIndices=visuals[1:], linkPositions=[[0, 0, 0]] * n,
                linkOrientations=[[0, 0, 0, 1]] * n, linkInertialFramePositions=[[0, 0, 0]] * n,
                linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=[0] * n,
                linkJointTypes=[w.JOINT_FIXED] * n, linkJointAxis=[[0, 0, 1]] * n)
            for link in range(-1, n):
                w.changeDynamics(b, link, lateralFriction=p.friction,
                                 collisionMargin=p.collision_margin_m)
            self.body[pid], self.ref[pid] = b, ref
        self.placed = [program.fixture]
        self.q = np.array(self.ik.model.home)

    def goal_ok(self, pid) -> bool:
        pos, orn = self.world.getBasePositionAndOrientation(self.body[pid])
        err = float(np.linalg.norm(np.array(pos) - self.ref[pid]))
        ang = 2 * math.acos(min(1.0, abs(orn[3])))
        return err <= self.p.pos_tol * self.extent_m[pid] and ang <= self.p.angle_tol_rad

    def move_tcp(self, target) -> bool:
        """Set the arm's joints to reach ``target`` (warm-started IK); whether it was reached."""
        from rap.robot.kinematics import POS_TOL_M

        q, err, _, _ = self.ik.solve(target, self.q)
        self.q = q
        return err < POS_TOL_M

    def arm_touches(self) -> bool:
        w = self.world
        w.performCollisionDetection()
        return any(w.getContactPoints(self.ik.arm, self.body[pid]) for pid in self.placed)


def _carry(scene, pid, offset, target) -> bool:
    reached = scene.move_tcp(target)
    scene.world.resetBasePositionAndOrientation(scene.body[pid], list(map(float, target - offset)),
                                                [0, 0, 0, 1])
    scene.world.resetBaseVelocity(scene.body[pid], [0, 0, 0], [0, 0, 0])
    return reached


def _run_trial(program, assembly, p, rng, counts, frames, camera, make_solver):
    scene = _Scene(program, assembly, p, make_solver)
    w, dt, ok = scene.world, p.dt_s, True
    try:
        for j, pid in enumerate(assembly.ids):  # parts not yet placed wait far off the cell
            if pid != program.fixture:
                w.resetBasePositionAndOrientation(
                    scene.body[pid], list(map(float, scene.ref[pid] + [5.0 + 0.5 * j, 5.0, 0])),
                    [0, 0, 0, 1])
        for k, step in enumerate(program.steps):
            c = counts[k]
            pid = step.part
            grasp_world = program.frame.point(step.grasp.point, step.grasp.depth_m)
            offset = grasp_world - scene.ref[pid]
            mass = sum(w.getDynamicsInfo(scene.body[pid], link)[0]
                       for link in range(-1, w.getNumJoints(scene.body[pid])))
            touched, reached = False, True
            perp = np.cross(step.insertion, program.frame.depth_axis)
            if program.frame.plane == "horizontal":
                perp = np.cross(program.frame.depth_axis, step.insertion)
            perp = perp / (np.linalg.norm(perp) or 1.0)
            if not p.errors.is_zero:  # along, across (mm) in the insertion's frame
                along, across, _ = p.errors.offsets(rng, (1.0, 0.0), 1.0)
                offset = offset - (across * perp + along * np.asarray(step.insertion)) / 1000.0
            for name in ("pick_above", "pick", "lift", "transit", "approach"):
                reached &= _carry(scene, pid, offset, np.array(step.waypoint(name).position))
                touched |= scene.arm_touches()
                if frames is not None:
                    frames.append(camera(w))
            tcp = w.getLinkState(scene.ik.arm, scene.ik.model.tcp_link)
            rel_pos, rel_orn = w.multiplyTransforms(
                *w.invertTransform(tcp[4], tcp[5]),
                *w.getBasePositionAndOrientation(scene.body[pid]))
            cid = w.createConstraint(scene.ik.arm, scene.ik.model.tcp_link, scene.body[pid], -1,
                                     w.JOINT_FIXED, [0, 0, 0], rel_pos, [0, 0, 0], rel_orn)
            w.changeConstraint(cid, maxForce=p.hold_force_n)
            for link in range(-1, w.getNumJoints(scene.ik.arm)):
                w.setCollisionFilterPair(scene.ik.arm, scene.body[pid], link, -1, 0)
            path = [np.array(step.waypoint(n).position) for n in ("approach", "start", "goal")]
            speed = program.cell.motion.insertion_speed_m_s
            n_frame = 0
            body, arm, model = scene.body[pid], scene.ik.arm, scene.ik.model
            for a, b in zip(path, path[1:]):
                n = max(1, int(math.ceil(np.linalg.norm(b - a) / (speed * dt))))
                q0 = scene.q
                for i0 in range(0, n, p.ik_every):  # IK at knots, joints interpolated between
                    i1 = min(n, i0 + p.ik_every)
                    reached &= scene.move_tcp(a + (b - a) * i1 / n)
                    q1 = scene.q
                    for i in range(i0 + 1, i1 + 1):
                        set_joints(w, arm, model, q0 + (q1 - q0) * (i - i0) / (i1 - i0))
                        f = rng.uniform(-p.eta, p.eta) * mass * p.noise_accel_m_s2
                        at = w.getBasePositionAndOrientation(body)[0]
                        w.applyExternalForce(body, -1, list(map(float, f * perp)), at,
                                             w.WORLD_FRAME)
                        w.stepSimulation()
                        n_frame += 1
                        if frames is not None and n_frame % 24 == 0:
                            frames.append(camera(w))
                    q0 = q1
                    touched |= bool(any(w.getContactPoints(arm, scene.body[o])
                                        for o in scene.placed))
            for _ in range(int(p.settle_s / dt)):
                w.stepSimulation()
            c.reached += reached
            inserted = scene.goal_ok(pid)
            c.inserted += inserted
            c.jammed += not inserted
            w.removeConstraint(cid)
            scene.placed.append(pid)
            scene.move_tcp(np.array(step.waypoint("retreat").position))
            for link in range(-1, w.getNumJoints(arm)):  # clear of it: the arm may hit it again
                w.setCollisionFilterPair(arm, body, link, -1, 1)
            for _ in range(int(p.settle_s / dt)):
                w.stepSimulation()
            if frames is not None:
                frames.append(camera(w))
            c.arm_contacts += touched
            c.displaced += not all(scene.goal_ok(q) for q in scene.placed[:-1])
            if not inserted:
                ok = False
                break
        ok = ok and all(scene.goal_ok(q) for q in scene.placed)
    finally:
        w.disconnect()
    return ok


def run_arm(program: Program, assembly: Assembly, trials: int = 10, seed: int = 0,
            params: ArmSimParams = DEFAULT_ARM_SIM, frames: list | None = None,
            camera=None) -> ArmOutcome:
    """Run ``program`` ``trials`` times (module doc). ``frames``: a list that receives the images
    of trial 0 (``camera(world)`` makes one; ``rap.robot.gif.camera``)."""
    t0 = time.perf_counter()
    counts = tuple(StepCounts() for _ in program.steps)
    make_solver = solver_for(program)
    wins = 0
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(trials)):
        rng = np.random.default_rng(child)
        wins += _run_trial(program, assembly, params, rng, counts,
                           frames if (i == 0 and frames is not None and camera) else None, camera,
                           make_solver)
    return ArmOutcome(rate(wins, trials), counts, time.perf_counter() - t0, frames or [])
