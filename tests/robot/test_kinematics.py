"""The kinematic check: a reachable plan passes; an assembly 3 m away exits 1 naming the step."""

from __future__ import annotations

from rap.robot.cell import Cell
from rap.robot.kinematics import check_program
from rap.robot.program import build_program

from tests.robot.cases import STACK, STACK_PLAN


def test_every_waypoint_and_line_of_the_stack_is_reached(stack):
    plan, _, asm = stack
    prog = build_program(plan, asm, Cell())
    report = check_program(prog)
    assert len(report.joints) == len(prog.waypoints) == 24
    # every movel segment sampled: 6 movel segments x 7 new points + 2 movej per step
    assert report.solves == 3 * (6 * (Cell().motion.samples_per_segment - 1) + 2)
    assert report.worst_position_m < 1e-4


def test_an_assembly_3_m_away_exits_1_naming_the_step(tmp_path, run_cli):
    cell = tmp_path / "far.toml"
    cell.write_text("[assembly]\nposition_m = [3.0, 0.0]\n")
    out = tmp_path / "far.script"
    code, _, err = run_cli("export", STACK_PLAN, "--assembly", STACK, "--cell", cell, "-o", out)
    assert code == 1
    line = err.strip()
    assert len(line.splitlines()) == 1
    assert "step 1 (block1)" in line and "waypoint transit at (3.000" in line
    assert "reach" in line or "limit" in line
    assert not out.exists()
