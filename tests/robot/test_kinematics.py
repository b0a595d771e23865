"""The kinematic check: a reachable plan passes; an assembly 3 m away exits 1 naming the step."""

from __future__ import annotations

import numpy as np

from rap.robot.arms.registry import ARMS
from rap.robot.cell import Cell
from rap.robot.kinematics import SAMPLE_STEP_M, check_program, line_samples
from rap.robot.program import build_program

from tests.robot.cases import STACK, STACK_PLAN


def test_every_waypoint_and_line_of_the_stack_is_reached(stack):
    plan, _, asm = stack
    prog = build_program(plan, asm, Cell())
    report = check_program(prog)
    assert len(report.joints) == len(prog.waypoints) == 24
    # every movel segment sampled at least 8 points and at most 5 mm apart, + the 2 movej a step
    n, prev, expect = Cell().motion.samples_per_segment, None, 0
    for w in prog.waypoints:
        line = w.motion == "movel" and prev is not None
        expect += len(line_samples(prev, w.position, n, SAMPLE_STEP_M)) if line else 1
        prev = w.position
    assert report.solves == expect == sum(len(p) for p in report.paths)
    assert report.worst_position_m < 1e-4
    lo, hi = np.array(ARMS["panda"].lower), np.array(ARMS["panda"].upper)
    assert all(((p >= lo) & (p <= hi)).all() for p in report.paths)  # the maker's limits


def test_an_assembly_3_m_away_exits_1_naming_the_step(tmp_path, run_cli):
    cell = tmp_path / "far.toml"
    cell.write_text("[assembly]\nposition_m = [3.0, 0.0]\n")
    out = tmp_path / "far.yaml"
    code, _, err = run_cli("export", STACK_PLAN, "--assembly", STACK, "--cell", cell, "-o", out)
    assert code == 1
    line = err.strip()
    assert len(line.splitlines()) == 1
    assert "step 1 (block1)" in line and "waypoint transit at (3.000" in line
    assert "reach" in line or "limit" in line
    assert not out.exists()
