"""The UR check: one IK branch along the whole program, samples 1 mm apart, and an unreachable
cell exits 1 naming the step."""

from __future__ import annotations

import numpy as np
import pytest

from rap.robot.arms import ur
from rap.robot.arms.registry import ARMS
from rap.robot.arms.ur_check import SAMPLE_STEP_M, check_ur
from rap.robot.cell import Cell, with_
from rap.robot.kinematics import Unreachable
from rap.robot.program import build_program

from tests.robot.cases import STACK, STACK_PLAN


@pytest.mark.parametrize("arm", ["ur5e", "ur10e"])
def test_one_branch_along_the_program(stack, arm):
    plan, _, asm = stack
    prog = build_program(plan, asm, with_(Cell(), "robot", arm=arm))
    report = check_ur(prog)
    spec = ARMS[arm]
    q = np.vstack(report.paths)
    assert len(report.paths) == len(prog.waypoints) == 24 and report.solves == len(q)
    codes = ur.branch_codes(spec.dh, q)
    assert (codes == codes[0]).all() and str(ur.branch_of(spec.dh, q[0])) == report.branch
    assert report.worst_position_m < 1e-9
    # every sample of a line at most 1 mm from the last; joints continuous (no 2 pi jumps)
    prev = None
    for w, path in zip(prog.waypoints, report.paths):
        if w.motion == "movel" and prev is not None:
            d = np.linalg.norm(np.diff(np.vstack([prev, [w.position]]), axis=0), axis=1)
            assert len(path) >= round(d.sum() / SAMPLE_STEP_M)
        prev = w.position
    assert np.abs(np.diff(q, axis=0)).max() < np.pi
    assert ((q >= spec.lower) & (q <= spec.upper)).all()


def test_an_assembly_out_of_reach_exits_1_naming_the_step(tmp_path, run_cli):
    cell = tmp_path / "far.toml"
    cell.write_text('[robot]\narm = "ur5e"\n[assembly]\nposition_m = [1.5, 0.0]\n')
    out = tmp_path / "far.script"
    code, _, err = run_cli("export", STACK_PLAN, "--assembly", STACK, "--cell", cell, "-o", out)
    line = err.strip()
    assert code == 1 and len(line.splitlines()) == 1 and not out.exists()
    assert "step 1 (block1), waypoint transit at (1.500" in line
    assert "beyond the ur5e's reach (0.85 m)" in line


def test_a_tray_at_the_base_meets_the_shoulder_singularity(stack):
    plan, _, asm = stack
    cell = with_(with_(Cell(), "robot", arm="ur5e"), "tray", origin_m=(0.0, 0.05))
    with pytest.raises(Unreachable) as err:
        check_ur(build_program(plan, asm, cell))
    msg = str(err.value)
    assert msg.startswith("step 1 (block1), waypoint pick_above at (0.000, 0.050")
    assert "shoulder singularity" in msg or "reach" in msg or "branch" in msg
