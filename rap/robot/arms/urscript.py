"""URScript for a Universal Robots arm: joint targets on the checked branch, TCP and payload set.

``urscript(program, report)`` writes one ``def rap_farm_program(): ... end`` from a ``Program``
and its UR check (``rap.robot.arms.ur_check.check_ur``'s ``KinematicReport``, whose joint vectors
are all on one IK branch):

* ``set_tcp(p[0, 0, tool_offset_m, 0, 0, 0])``: the cup's offset from the flange, so that every
  pose below is the cup's;
* ``set_target_payload(m, [cx, cy, cz])``: the cup alone (``gripper.mass_kg``, its centre half
  way down the offset) at the start and after each release; the cup and the part (its mass:
  area x ``thickness_m`` x ``density_kg_m3``, its centroid as held) after each grip;
* ``movej([q1, ..., q6], a=, v=)``: the free-space moves (``pick_above``, ``transit``) to the
  checked joint vector, so the controller chooses no branch;
* ``movel(p[x, y, z, rx, ry, rz], a=, v=, r=0)``: the straight moves (pick, lift, approach, the
  insertion, retreat), with blend radius 0: the arm stops on every one;
* the vacuum: ``set_digital_out(OUTPUT, True/False)`` then ``sleep(GRIP_SETTLE_S)``.

``movej``'s speed is the cell's ``joint_speed_rad_s``, capped at the arm's slowest joint's
maximum. Numbers with 6 decimals. Cost: O(waypoints).
"""

from __future__ import annotations

from rap.robot.arms.registry import arm_spec
from rap.robot.arms.ur_check import SAMPLE_STEP_M
from rap.robot.kinematics import KinematicReport
from rap.robot.program import Program

__all__ = ["urscript", "GRIP_SETTLE_S"]

GRIP_SETTLE_S = 0.2


def _n(x: float) -> str:
    return f"{round(float(x), 6) + 0.0:.6f}"


def _vec(values) -> str:
    return "[" + ", ".join(_n(v) for v in values) + "]"


def _payload(mass: float, cog) -> str:
    return f"  set_target_payload({_n(mass)}, {_vec(cog)})"


def urscript(program: Program, report: KinematicReport) -> str:
    """The URScript program (module doc) of ``program`` on its cell's UR arm, with the joint
    vectors of ``report``."""
    cell, spec = program.cell, arm_spec(program.cell.robot.arm)
    g, out = cell.gripper, cell.gripper.output
    v_joint = min(cell.motion.joint_speed_rad_s, min(spec.max_velocity))
    tool_cog = (0.0, 0.0, g.tool_offset_m / 2)
    lines = [f"# rap-farm robot program for the {spec.title}: assembly {program.assembly}, "
             f"{len(program.steps)} steps, fixture {program.fixture}, cell {cell.source}",
             f"# joint targets (rad) on one IK branch ({report.branch}), checked every "
             f"{SAMPLE_STEP_M * 1000:g} mm along each line; poses p[x, y, z, rx, ry, rz] of the "
             f"TCP (m, rotation vector) in the base frame, the tool pointing down",
             "def rap_farm_program():",
             f"  set_tcp(p[0, 0, {_n(g.tool_offset_m)}, 0, 0, 0])",
             _payload(g.mass_kg, tool_cog),
             f"  set_digital_out({out}, False)"]
    joints = iter(report.joints)
    for s in program.steps:
        i = s.insertion
        score = "?" if s.score is None else f"{s.score:.2f}"
        lines.append(f"  # step {s.index}: {s.part} into {{{','.join(s.fixed)}}}, insertion "
                     f"({i[0] + 0.0:.3f}, {i[1] + 0.0:.3f}, {i[2] + 0.0:.3f}), score {score}, "
                     f"part {s.mass_kg * 1000:.1f} g")
        for w in s.waypoints:
            q = next(joints)
            if w.motion == "movej":
                lines.append(f"  movej({_vec(q)}, a={w.acceleration:g}, v={v_joint:g})"
                             f"  # {w.name}")
            else:
                pose = "p" + _vec((*w.position, *w.rotvec))
                lines.append(f"  movel({pose}, a={w.acceleration:g}, v={w.speed:g}, r=0)"
                             f"  # {w.name}")
            if w.action:
                on = w.action == "grip_on"
                lines.append(f"  set_digital_out({out}, {'True' if on else 'False'})")
                lines.append(f"  sleep({GRIP_SETTLE_S:g})")
                if on:
                    m = g.mass_kg + s.mass_kg
                    c = s.cog_m  # base frame, from the TCP; the tool frame: (x, -y, -z) + offset
                    part = (c[0], -c[1], g.tool_offset_m - c[2])
                    cog = [(g.mass_kg * t + s.mass_kg * p) / m for t, p in zip(tool_cog, part)]
                    lines.append(_payload(m, cog))
                else:
                    lines.append(_payload(g.mass_kg, tool_cog))
    lines.append("end")
    return "\n".join(lines) + "\n"
