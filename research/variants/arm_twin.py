"""The arm's planar twin: whole-plan rollouts in which the placed parts are free bodies and the part
rides a stiff cup along the insertion, as the simulated arm executes a one-arm plan. Measured not
to predict the arm better than the shipped rollouts (research/README.md, "The arm's planar twin"),
so it is kept here.

    python -m research.variants.arm_twin [--rollouts 200] [--margin-mm 0.1] [--friction 0.3]
        [--case NAME=PLAN:ASSEMBLY ...]

The shipped rollouts (``rap.execution.rollout``) keep the placed parts static and drive the part
with the robustness simulator's soft controller. The arm in pybullet (``rap.robot.arm_sim``) is
neither: its placed parts are free (a later insertion can push one off its place) and the part
hangs on a position-controlled cup by a hold of ``hold_force_n``, a hundred times a small part's
weight. ``run_twin_chunk`` rolls a plan out in that model, in the plane (pymunk), in millimetres,
kilograms and seconds:

* **Parts**: each part's convex pieces (``rap.sim.outline``, as the rollouts simulate them) in mm,
  shrunk by ``inset_mm`` as the arm's prisms are (``rap.sim.shapes.shrunk_piece``) and rounded by
  ``margin_mm`` (Bullet's collision margin), of mass ``density_kg_m3 x thickness_mm`` per area.
  ``friction`` is the coefficient of a contact: Chipmunk multiplies the two shapes' coefficients,
  so each shape gets its square root. The fixture (the plan's base) is static; every other placed
  part is a dynamic body where the earlier steps of this rollout left it.
* **Weight**: with the plan's gravity (a wall standing up) the space's gravity is 9.81 m/s^2 along
  it, and the table is a line under the assembly's lowest point (``rap.robot.frames`` puts it
  there); without, each free body is held by table friction: a pivot and a gear joint to the
  table of at most ``friction x m g`` and ``friction x m g x`` its radius of gyration (Chipmunk's
  top-down friction).
* **The cup**: a kinematic body moving from the step's start (``rap.sim.placement``, the
  simulator's and the plan's start pose) to its goal at ``speed_mm_s``; the part hangs on it,
  off by one draw of the cell's ``ErrorModel`` (position only: the arm's cup holds the part
  square, as ``arm_sim`` does), by a pivot joint of at most ``hold_force_n`` and a gear joint of
  at most ``hold_force_n x cup_radius_mm``. With ``ErrorModel.force_noise`` the simulator's
  actuation noise acts on the part across the insertion while the cup moves: ``U(-eta, eta) x m
  x g`` a physics step (``arm_sim``'s).
* **A step**: the cup reaches the goal, holds ``settle_s``, the step is judged (**inserted** when
  its parts lie within the tolerance of their goal: ``pos_tol`` of each part's extent,
  ``angle_tol_rad``), the part is released and everything settles ``settle_s`` more. A rollout
  fails at its first step not inserted; **at the end** every part must lie within the tolerance
  (the arm's final check), else it fails at the step after which a part that ends off its goal
  was last found within it.

Seeds: rollout ``i``'s step ``k`` draws its grasp error first, then its noise, from
``rap.execution.rollout.step_rng(root_seed, i, k)`` (the rollouts' generator). Each rollout has
its own space, so a result depends on the root seed, the index and the plan alone.

Cost: one Chipmunk step per ``dt_s`` of motion (travel / speed + 2 ``settle_s`` a step) with the
placed parts' contacts: the 22-brick wall about 0.45 s a rollout on one core.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pymunk

from rap.assembly import Assembly
from rap.execution.rollout import ChunkOutcome, RolloutPlan, step_rng
from rap.sim.outline import assembly_outlines
from rap.sim.placement import placement
from rap.sim.shapes import area_centroid, shrunk_piece

__all__ = ["ArmTwin", "run_twin_chunk", "twin_of", "GRAVITY_MM_S2", "ARM_MEASURED"]

GRAVITY_MM_S2 = 9810.0


@dataclass(frozen=True)
class ArmTwin:
    """The arm's physical constants in the twin (module doc); ``twin_of`` fills them from the cell,
    the plan and ``rap.robot.arm_sim.ArmSimParams``."""

    fixture: str
    gravity: tuple[float, float] | None = None  # direction in the assembly's plane, or None
    thickness_mm: float = 20.0
    density_kg_m3: float = 700.0
    friction: float = 0.3
    hold_force_n: float = 20.0
    cup_radius_mm: float = 6.0
    speed_mm_s: float = 20.0
    inset_mm: float = 0.2
    margin_mm: float = 0.1  # each piece rounded by this (Bullet's collision margin)
    settle_s: float = 0.25
    dt_s: float = 1.0 / 240.0
    iterations: int = 30

    def __post_init__(self):
        for k in ("thickness_mm", "density_kg_m3", "hold_force_n", "cup_radius_mm", "speed_mm_s",
                  "dt_s"):
            v = getattr(self, k)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{k} must be > 0, not {v!r}")
        if self.gravity is not None and not any(self.gravity):
            raise ValueError("gravity must be a non-zero direction or None")


class _World:
    """One rollout's space: the fixture, the placed bodies and where each part belongs."""

    def __init__(self, assembly: Assembly, plan: RolloutPlan, twin: ArmTwin):
        self.plan, self.twin, self.mm = plan, twin, plan.mm_per_unit
        p = plan.params
        self.outlines = assembly_outlines(assembly, p.shape_tolerance, p.shape_pieces)
        self.space = s = pymunk.Space()
        s.iterations = twin.iterations
        s.collision_slop = 0.02  # mm
        if twin.gravity is not None:
            gx, gy = twin.gravity
            n = math.hypot(gx, gy)
            s.gravity = (GRAVITY_MM_S2 * gx / n, GRAVITY_MM_S2 * gy / n)
        self.area_density = twin.density_kg_m3 * twin.thickness_mm * 1e-9  # kg per mm^2
        self.goal: dict[str, tuple[float, float]] = {}  # part -> its centroid in place, mm
        self.tol: dict[str, float] = {}  # part -> position tolerance, mm
        for pid in assembly.ids:
            pts = [(x * self.mm, y * self.mm) for pc in self.outlines[pid] for x, y in pc]
            _, cx, cy = area_centroid([[(x * self.mm, y * self.mm) for x, y in pc]
                                       for pc in self.outlines[pid]])
            self.goal[pid] = (cx, cy)
            xs, ys = [q[0] for q in pts], [q[1] for q in pts]
            self.tol[pid] = p.pos_tol * max(max(xs) - min(xs), max(ys) - min(ys))
        if twin.gravity is not None:  # the table: a line under the lowest point (rap.robot.frames)
            ux, uy = -s.gravity[0] / GRAVITY_MM_S2, -s.gravity[1] / GRAVITY_MM_S2
            every = [(x * self.mm, y * self.mm) for pid in assembly.ids
                     for pc in self.outlines[pid] for x, y in pc]
            low = min(x * ux + y * uy for x, y in every)
            span = 10 * max(max(abs(x), abs(y)) for x, y in every) + 1000.0
            a = (low * ux + span * uy, low * uy - span * ux)
            b = (low * ux - span * uy, low * uy + span * ux)
            table = pymunk.Segment(s.static_body, a, b, 0.0)
            table.friction = math.sqrt(twin.friction)
            s.add(table)
        self.part_body: dict[str, pymunk.Body] = {}  # placed part -> the body it rides
        self._local: dict[str, tuple[float, float]] = {}  # placed part -> its centroid on it
        for pc in self.outlines[twin.fixture]:
            s.add(self._poly(s.static_body, pc, (0.0, 0.0)))

    def _poly(self, body, piece, origin) -> pymunk.Poly:
        ox, oy = origin
        pts = shrunk_piece([(x * self.mm - ox, y * self.mm - oy) for x, y in piece],
                           self.twin.inset_mm)
        shape = pymunk.Poly(body, pts, radius=self.twin.margin_mm)
        shape.density = self.area_density
        shape.friction = math.sqrt(self.twin.friction)  # Chipmunk multiplies the two shapes'
        shape.elasticity = 0.0
        return shape

    def new_body(self, parts) -> tuple[pymunk.Body, tuple[float, float]]:
        """A dynamic body of ``parts`` in their assembled place (its position: their centroid)."""
        pieces = [pc for pid in sorted(parts) for pc in self.outlines[pid]]
        _, cx, cy = area_centroid([[(x * self.mm, y * self.mm) for x, y in pc] for pc in pieces])
        body = pymunk.Body()
        body.position = (cx, cy)
        self.space.add(body, *(self._poly(body, pc, (cx, cy)) for pc in pieces))
        return body, (cx, cy)

    def on_table(self, body: pymunk.Body) -> None:
        """Table friction for a free body lying on the table (no gravity in the plane)."""
        if self.twin.gravity is not None:
            return
        f = self.twin.friction * body.mass * GRAVITY_MM_S2
        pivot = pymunk.PivotJoint(self.space.static_body, body, (0, 0), (0, 0))
        gear = pymunk.GearJoint(self.space.static_body, body, 0.0, 1.0)
        pivot.max_bias = gear.max_bias = 0.0
        pivot.max_force = f
        gear.max_force = f * math.sqrt(body.moment / body.mass)
        self.space.add(pivot, gear)

    def within(self, pid: str) -> bool:
        """Whether part ``pid`` lies within the tolerance of its goal."""
        body = self.part_body[pid]
        at = body.local_to_world(self._local[pid])
        gx, gy = self.goal[pid]
        ang = (body.angle + math.pi) % (2 * math.pi) - math.pi
        return math.hypot(at[0] - gx, at[1] - gy) <= self.tol[pid] and \
            abs(ang) <= self.plan.params.angle_tol_rad

    def place(self, parts, body, centre) -> None:
        """``parts`` ride ``body``, whose position is ``centre`` when they are in place."""
        for pid in parts:
            self.part_body[pid] = body
            self._local[pid] = (self.goal[pid][0] - centre[0], self.goal[pid][1] - centre[1])

    def run(self, seconds: float) -> None:
        for _ in range(max(1, int(round(seconds / self.twin.dt_s)))):
            self.space.step(self.twin.dt_s)


def _insert(world: _World, assembly: Assembly, op, rng) -> bool:
    """Step ``op`` of one rollout: the cup carries the part in and lets it go (module doc);
    whether it was inserted."""
    plan, twin, mm = world.plan, world.twin, world.mm
    grasp = plan.errors.offsets(rng, op.direction, plan.mm_per_unit)
    body, centre = world.new_body(op.moving)
    pl = placement(assembly, op, plan.params.start_gap)
    sx, sy = pl.start_offset[0] * mm, pl.start_offset[1] * mm
    cup = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    cup.position = (centre[0] + sx, centre[1] + sy)
    body.position = (cup.position[0] + grasp[0] * mm, cup.position[1] + grasp[1] * mm)
    hold = pymunk.PivotJoint(cup, body, (0, 0), body.world_to_local(cup.position))
    turn = pymunk.GearJoint(cup, body, 0.0, 1.0)
    hold.max_force = twin.hold_force_n * 1000.0  # N -> kg mm / s^2
    turn.max_force = twin.hold_force_n * twin.cup_radius_mm * 1000.0
    world.space.add(cup, hold, turn)
    length = pl.travel * mm
    n = max(1, int(math.ceil(length / (twin.speed_mm_s * twin.dt_s))))
    dx, dy = op.direction
    v = length / (n * twin.dt_s)
    cup.velocity = (dx * v, dy * v)
    noise = (plan.params.eta if plan.errors.force_noise else 0.0)
    pushes = (rng.uniform(-noise, noise, n) * body.mass * GRAVITY_MM_S2 if noise > 0 else None)
    for i in range(n):
        if pushes is not None:
            body.apply_force_at_local_point((-dy * pushes[i], dx * pushes[i]), (0, 0))
        world.space.step(twin.dt_s)
    cup.velocity = (0.0, 0.0)
    cup.position = centre  # exactly the goal (the step above ends there up to rounding)
    world.run(twin.settle_s)
    world.place(op.moving, body, centre)
    inserted = all(world.within(pid) for pid in op.moving)
    world.space.remove(hold, turn, cup)
    world.on_table(body)
    world.run(twin.settle_s)
    return inserted


def _rollout(assembly: Assembly, plan: RolloutPlan, twin: ArmTwin, root_seed: int,
             index: int) -> int:
    """One rollout: the 0-based step at which it failed, or -1."""
    world = _World(assembly, plan, twin)
    placed = {twin.fixture}
    last_within: dict[str, int] = {}  # part -> the last step after which it lay within tolerance
    for k, op in enumerate(plan.steps):
        if twin.fixture not in op.fixed or op.moving & placed or not op.fixed <= placed:
            raise ValueError(f"step {k + 1}: the arm's twin runs one-arm plans (each step moves "
                             f"parts not yet placed into the fixture's subassembly)")
        if not _insert(world, assembly, op, step_rng(root_seed, index, k)):
            return k
        placed |= op.moving
        last_within.update((pid, k - 1) for pid in op.moving)  # off after this step: fails here
        for pid in placed - {twin.fixture}:
            if world.within(pid):
                last_within[pid] = k
    off = [last_within[pid] + 1 for pid in placed - {twin.fixture}
           if not world.within(pid)]
    return min(min(off), len(plan.steps) - 1) if off else -1


def run_twin_chunk(assembly: Assembly, plan: RolloutPlan, twin: ArmTwin, root_seed: int,
                   first: int, count: int) -> ChunkOutcome:
    """Rollouts ``first .. first + count - 1`` of ``plan`` in the twin ``twin``."""
    t0 = time.perf_counter()
    failed = tuple(_rollout(assembly, plan, twin, root_seed, first + j) for j in range(count))
    return ChunkOutcome(first, failed, time.perf_counter() - t0)


#: the Panda in pybullet on these plans with the shipped cell's errors, seed 0, 30 runs each
#: (successes; docs/ROBOT.md, "The arm against the rollouts": ``benchmarks/arm_vs_rollouts.py
#: --runs 30``): what the twin is to predict
ARM_MEASURED = {"stack": 30, "tangram": 30, "arch-centring": 30, "pegs-s1": 30, "pegs-s2": 2,
                "packing-s3": 30, "brick-wall-22": 18}
ARM_RUNS = 30
CASES = [("stack", "tests/robot/data/stack.plan.json", "assemblies/cells/stack.json"),
         ("tangram", "tests/robot/data/tangram.plan.json", "assemblies/unseen/tangram.json"),
         ("brick-wall-22", "tests/robot/data/brick-wall-22.plan.json",
          "assemblies/cells/brick-wall-22.json")]


def twin_of(plan_doc: dict, cell, **changes) -> ArmTwin:
    """The twin of the arm that executes ``plan_doc`` (a plan file's document) in ``cell``: its
    fixture and gravity from the plan's constraints, the rest from the cell and ``ArmSimParams``."""
    from rap.robot.arm_sim import DEFAULT_ARM_SIM
    from rap.robot.frames import plan_gravity
    from rap.robot.program import fixture_of

    p = DEFAULT_ARM_SIM
    fields = dict(fixture=fixture_of(plan_doc.get("constraints")),
                  gravity=plan_gravity(plan_doc), thickness_mm=cell.assembly.thickness_m * 1000.0,
                  density_kg_m3=p.density_kg_m3, friction=p.friction,
                  hold_force_n=p.hold_force_n,
                  cup_radius_mm=cell.gripper.cup_diameter_m * 500.0, speed_mm_s=cell.motion.insertion_speed_m_s * 1000.0,
                  inset_mm=p.inset_m * 1000.0, margin_mm=p.collision_margin_m * 1000.0,
                  settle_s=p.settle_s, dt_s=p.dt_s)
    fields.update(changes)
    return ArmTwin(**fields)


def _chunk(job):
    assembly, plan, twin, first, count = job
    return run_twin_chunk(assembly, plan, twin, 0, first, count)


def main() -> None:
    import argparse
    from concurrent.futures import ProcessPoolExecutor
    from dataclasses import replace
    from pathlib import Path

    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.execution.rollout import chunks
    from rap.execution.sequence import tally
    from rap.robot.cell import Cell
    from rap.robot.inputs import load_plan_and_assembly
    from rap.robot.planar import run_planar
    from rap.sim.params import DEFAULT_PARAMS
    from rap.stats import rate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=200)
    ap.add_argument("--margin-mm", type=float, action="append",
                    help="the twin's collision margin (repeat for columns; default: the arm's)")
    ap.add_argument("--friction", type=float, help="the twin's contact friction (default: arm's)")
    ap.add_argument("--case", action="append", default=[], metavar="NAME=PLAN:ASSEMBLY")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    cases = list(CASES)
    for spec in args.case:
        name, _, paths = spec.partition("=")
        plan_path, _, asm_path = paths.partition(":")
        cases.append((name, plan_path, asm_path))
    cell = Cell()
    errors = replace(cell_errors(cell), force_noise=False)
    margins = args.margin_mm or [None]
    changes = {} if args.friction is None else {"friction": args.friction}
    heads = ["twin, the arm's margin" if m is None else f"twin, margin {m} mm" for m in margins]
    print("| plan | steps | arm, executed | rollouts, position errors only | "
          + " | ".join(heads) + " |")
    print("|---|---:|---|---|" + "---|" * len(margins))
    with ProcessPoolExecutor(args.workers) as pool:
        for name, plan_path, asm_path in cases:
            plan, doc, asm = load_plan_and_assembly(Path(plan_path), Path(asm_path))
            mm = mm_per_unit(cell, asm)
            shipped = run_planar(plan, asm, trials=args.rollouts, seed=0, errors=errors,
                                 mm_per_unit=mm).success
            cols = []
            for m in margins:
                twin = twin_of(doc, cell, **changes,
                               **({} if m is None else {"margin_mm": m}))
                rplan = RolloutPlan(tuple(s.to_operation() for s in plan.steps), DEFAULT_PARAMS,
                                    errors, mm)
                outs = list(pool.map(_chunk, [(asm, rplan, twin, f, c)
                                              for f, c in chunks(0, args.rollouts)]))
                wins, _, _, runs = tally(len(plan.steps), outs)
                cols.append(rate(wins, runs).text())
            arm = ARM_MEASURED.get(name)
            arm_text = rate(arm, ARM_RUNS).text() if arm is not None else "-"
            print(f"| {name} | {len(plan.steps)} | {arm_text} | {shipped.text()} | "
                  + " | ".join(cols) + " |", flush=True)


if __name__ == "__main__":
    main()
