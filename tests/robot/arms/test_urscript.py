"""The UR program: set_tcp, set_target_payload, joint-target movej on the checked branch, movel
with blend 0 on every straight move, accepted by the URScript grammar of tests/robot."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rap.robot.arms import ur
from rap.robot.arms.registry import ARMS
from rap.robot.arms.ur_check import check_ur
from rap.robot.arms.urscript import urscript
from rap.robot.cell import Cell, with_
from rap.robot.program import build_program

from tests.robot.test_writers import NUM, parse_urscript


def test_the_ur5e_program(stack):
    plan, _, asm = stack
    cell = with_(Cell(), "robot", arm="ur5e")
    prog = build_program(plan, asm, cell)
    report = check_ur(prog)
    text = urscript(prog, report)
    assert parse_urscript(text) == []
    lines = text.splitlines()
    assert lines[3] == "  set_tcp(p[0, 0, 0.040000, 0, 0, 0])"
    assert lines[4] == "  set_target_payload(0.100000, [0.000000, 0.000000, 0.020000])"
    movej = [ln for ln in lines if ln.startswith("  movej(")]
    movel = [ln for ln in lines if ln.startswith("  movel(")]
    assert len(movej) == 3 * 2 and len(movel) == 3 * 6
    assert all(", r=0)  # " in ln for ln in movel)
    assert {ln.rsplit("# ", 1)[1] for ln in movel} == {"pick", "lift", "approach", "start",
                                                        "goal", "retreat"}
    # joint targets: the check's joint vectors, on one branch
    spec = ARMS["ur5e"]
    qs = np.array([[float(v) for v in re.findall(NUM, ln.split("[")[1].split("]")[0])]
                   for ln in movej])
    codes = ur.branch_codes(spec.dh, qs)
    assert (codes == codes[0]).all()
    wps = [w for w in prog.waypoints if w.motion == "movej"]
    for q, w in zip(qs, wps):
        T = ur.fk(spec.dh, q)
        assert np.abs(T[:3, 3] - (np.array(w.position) + [0, 0, 0.04])).max() < 2e-6
    # the payload: the part's mass (area x 0.02 m x 700 kg/m3) on after each grip, off after
    grips = [i for i, ln in enumerate(lines) if ln == "  set_digital_out(0, True)"]
    block = float(asm.part("block1").area()) * 0.002 ** 2 * 0.02 * 700.0
    assert lines[grips[0] + 2].startswith(f"  set_target_payload({0.1 + block:.6f}, [")
    assert text.count("set_target_payload(") == 1 + 2 * 3


@pytest.mark.parametrize("arm", ["ur5e", "ur10e"])
def test_export_writes_the_urscript(arm, tmp_path, run_cli):
    from tests.robot.cases import STACK, STACK_PLAN

    out = tmp_path / "p.script"
    code, text, _ = run_cli("export", STACK_PLAN, "--assembly", STACK, "--arm", arm, "-o", out)
    assert code == 0 and f"reached by the {arm}" in text and "IK branch shoulder front" in text
    assert parse_urscript(out.read_text()) == []
