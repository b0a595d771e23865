"""A plan as one arm's program: Cartesian waypoints in the robot's base frame, with gripper actions.

``build_program(plan, assembly, cell)`` turns a found plan (``rap.plan.report.result.PlanResult``, its
steps carrying their robot poses: ``rap-farm plan --out``) into a ``Program``. Each step moves one
part from its tray slot into the fixture, through eight waypoints (the tool pointing down,
``TOOL_DOWN_ROTVEC``; TCP = the suction cup's centre on the part, ``rap.robot.grasp``):

======== ======= =========================================================================
name     motion  where
======== ======= =========================================================================
pick_above movej the tray slot, ``approach_height_m`` up
pick     movel   on the part in the tray; then **grip on** (vacuum)
lift     movel   back to ``pick_above``
transit  movej   on the insertion line beyond the approach, high enough to clear the
                 assembly (``approach - t * insertion``; straight above the approach when the
                 insertion does not go down)
approach movel   the plan's ``approach`` pose (``linear_speed_m_s``)
start    movel   the plan's ``start`` pose (``insertion_speed_m_s``)
goal     movel   the plan's ``goal`` pose, the part in place; then **grip off**
retreat  movel   ``approach_height_m`` straight up
======== ======= =========================================================================

A plan pose ``P`` (a translation of the moving part in assembly units) is the TCP at
``frame.point(grasp + P, grasp depth)`` (``rap.robot.frames``): the ``approach``, ``start`` and
``goal`` waypoints are exactly the plan's poses in the base frame. A tray waypoint's TCP is the
slot at the grasp's height above the table.

One arm and one fixture: the plan must name a fixture (``constraints.base``, ``plan --base``),
and every step must move one part into a subassembly that holds the fixture (``plan --linear``).
Otherwise ``TwoHandedPlan`` (exit 1), one line naming the step: a step that moves a subassembly,
or builds one away from the fixture, needs a second hand and a second fixture.

Each step carries its part's mass (area x ``thickness_m`` x ``density_kg_m3``) and centroid
from the TCP, for the payload a program sets (``rap.robot.arms.urscript``).

Cost: O(parts x vertices) (grasps) plus O(1) a waypoint; no kinematics (``rap.robot.kinematics``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rap.assembly import Assembly
from rap.errors import EXIT_INFEASIBLE, InputError, RapError
from rap.plan.report.poses import centroid
from rap.plan.report.result import PlanResult
from rap.robot.cell import Cell
from rap.robot.frames import TOOL_DOWN_ROTVEC, CellFrame, cell_frame, plan_gravity
from rap.robot.grasp import Grasp, grasp_point, tray_slots

__all__ = ["Waypoint", "ProgramStep", "Program", "TwoHandedPlan", "build_program",
           "WAYPOINT_NAMES", "fixture_of"]

WAYPOINT_NAMES = ("pick_above", "pick", "lift", "transit", "approach", "start", "goal", "retreat")


class TwoHandedPlan(RapError):
    """A plan one arm cannot build (module doc). Exit status 1."""

    exit_code = EXIT_INFEASIBLE


@dataclass(frozen=True)
class Waypoint:
    """One move of the program: to ``position`` (metres, base frame) with the tool's rotation
    vector ``rotvec``; ``motion`` ``movej`` or ``movel``; ``speed`` (rad/s for movej, m/s for
    movel) and ``acceleration``; ``action`` after arriving: ``"grip_on"``, ``"grip_off"`` or
    ``""``. ``step`` is 1-based, ``part`` the part carried (or about to be)."""

    step: int
    name: str
    motion: str
    position: tuple[float, float, float]
    rotvec: tuple[float, float, float]
    speed: float
    acceleration: float
    action: str
    part: str


@dataclass(frozen=True)
class ProgramStep:
    """A step of the program: which part goes where (what the arm simulation needs too)."""

    index: int  # 1-based
    part: str
    fixed: tuple[str, ...]
    insertion: np.ndarray  # [3] unit, base frame
    grasp: Grasp
    slot: tuple[float, float]
    score: float | None
    waypoints: tuple[Waypoint, ...]
    mass_kg: float = 0.0  # the part's: area x thickness_m x density_kg_m3
    cog_m: tuple[float, float, float] = (0.0, 0.0, 0.0)  # its centroid from the TCP, base frame

    def waypoint(self, name: str) -> Waypoint:
        return next(w for w in self.waypoints if w.name == name)


@dataclass(frozen=True)
class Program:
    """The whole program: ``fixture`` (the part held from the start), the frame, the steps."""

    assembly: str
    fixture: str
    frame: CellFrame
    cell: Cell
    steps: tuple[ProgramStep, ...]

    @property
    def waypoints(self) -> list[Waypoint]:
        return [w for s in self.steps for w in s.waypoints]


def fixture_of(plan_doc_constraints: dict | None) -> str | None:
    """The fixture part a plan was made with (``constraints.base``), or None."""
    base = (plan_doc_constraints or {}).get("base")
    return str(base) if base else None


def _check_one_arm(plan: PlanResult, fixture: str | None) -> None:
    if fixture is None:
        raise TwoHandedPlan(
            "the plan has no fixture (made without --base), so its first step joins two loose "
            "parts: a two-handed step needs a second fixture; plan with --base PART --linear")
    for k, s in enumerate(plan.steps, 1):
        if len(s.moving) > 1:
            raise TwoHandedPlan(
                f"step {k} moves {{{','.join(s.moving)}}} ({len(s.moving)} parts): one arm "
                f"holds one part; a two-handed step needs a second fixture (plan with --linear)")
        if fixture not in s.fixed:
            raise TwoHandedPlan(
                f"step {k} joins {s.moving[0]} to {{{','.join(s.fixed)}}} away from the fixture "
                f"{fixture}: a two-handed step needs a second fixture (plan with --linear)")
        if s.robot is None:
            raise InputError(f"step {k} carries no robot poses (a plan file of an older "
                             f"version): plan again with rap-farm plan --out")


def _rot() -> tuple[float, float, float]:
    return tuple(float(v) for v in TOOL_DOWN_ROTVEC)  # type: ignore[return-value]


def build_program(plan: PlanResult, assembly: Assembly, cell: Cell) -> Program:
    """The program of ``plan`` (module doc); its fixture and gravity are the plan's
    ``constraints`` (``base``, ``gravity``), which ``PlanResult.from_json`` keeps in ``stats``.
    Raises ``TwoHandedPlan`` (exit 1), ``GraspError`` (exit 2)."""
    constraints = plan.stats.get("constraints")
    fixture = fixture_of(constraints)
    _check_one_arm(plan, fixture)
    frame = cell_frame(cell, assembly, plan_gravity({"constraints": constraints}))
    m = cell.motion
    h = m.approach_height_m
    up = np.array([0.0, 0.0, 1.0])
    parts = [s.moving[0] for s in plan.steps]
    grasps = {p: grasp_point(assembly, p, frame, cell) for p in parts}
    slots = tray_slots(parts, assembly, frame, cell)
    tops = [frame.point(xy, frame.top_depth())[2] for pid in assembly.ids
            for xy in assembly.part(pid).float_outer()]
    clear_z = max(tops) + h
    rot = _rot()
    steps = []
    for k, s in enumerate(plan.steps, 1):
        part, g, r = s.moving[0], grasps[s.moving[0]], s.robot
        ins = frame.direction(s.insertion)

        def tcp(pose, g=g):
            return frame.point((g.point[0] + pose[0], g.point[1] + pose[1]), g.depth_m)

        slot = slots[part]
        pick = np.array([slot[0], slot[1], frame.table_z + g.height_m])
        approach = tcp(r.approach)
        need = clear_z + g.height_m  # the part's bottom above the assembly's top
        if ins[2] < -1e-9 and approach[2] < need:
            transit = approach - ((need - approach[2]) / -ins[2]) * ins
        else:
            transit = np.array([approach[0], approach[1], max(need, approach[2])])

        def wp(name, motion, pos, action="", insertion=False):
            speed = (m.joint_speed_rad_s if motion == "movej" else
                     m.insertion_speed_m_s if insertion else m.linear_speed_m_s)
            acc = m.joint_acceleration_rad_s2 if motion == "movej" else m.linear_acceleration_m_s2
            return Waypoint(k, name, motion, tuple(float(v) + 0.0 for v in pos), rot,
                            speed, acc, action, part)

        wps = (wp("pick_above", "movej", pick + h * up),
               wp("pick", "movel", pick, "grip_on"),
               wp("lift", "movel", pick + h * up),
               wp("transit", "movej", transit),
               wp("approach", "movel", approach),
               wp("start", "movel", tcp(r.start), insertion=True),
               wp("goal", "movel", tcp(r.goal), "grip_off", insertion=True),
               wp("retreat", "movel", tcp(r.goal) + h * up))
        mass = (float(assembly.part(part).area()) * frame.scale_m ** 2 * frame.thickness_m
                * cell.assembly.density_kg_m3)
        mid = frame.thickness_m / 2 if frame.plane == "horizontal" else 0.0
        cog = frame.point(centroid(assembly, [part]), mid) - tcp((0.0, 0.0))
        steps.append(ProgramStep(k, part, s.fixed, ins, g, slot, s.score, wps, mass,
                                 tuple(float(v) for v in cog)))
    return Program(plan.assembly, fixture, frame, cell, tuple(steps))
