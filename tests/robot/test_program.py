"""The program: the plan's poses, transformed into the base frame; one arm or a refusal."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from rap.plan.report.result import PlanResult
from rap.robot.cell import Cell, with_
from rap.robot.program import TwoHandedPlan, build_program

from tests.robot.cases import STACK, STACK_PLAN, TANGRAM, TANGRAM_PLAN


def test_waypoints_are_the_plan_poses_in_the_base_frame(stack):
    plan, doc, asm = stack
    prog = build_program(plan, asm, Cell())
    scale = 0.002  # default unit_m; the stack's units are "unit"
    # vertical plane (the plan has gravity 0,-1): x -> base x, y -> base z; anchor: middle of the
    # bounding box in x (plate 0..40: 20), its bottom in y (0) at (0.5, 0, table 0)
    for s, js in zip(prog.steps, doc["steps"]):
        gx, gy = s.grasp.point
        for name in ("approach", "start", "goal"):
            px, py = js["robot"][name]
            expect = (0.5 + scale * (gx + px - 20), 0.0, scale * (gy + py - 0))
            assert np.allclose(s.waypoint(name).position, expect, atol=1e-12), (s.index, name)
        # the cup sits on the block's top edge, above its centroid
        cx, cy = js["robot"]["centroid"]["goal"]
        assert gx == pytest.approx(cx) and gy == pytest.approx(cy + 5)
    assert [w.action for w in prog.steps[0].waypoints].count("grip_on") == 1
    assert prog.steps[0].waypoint("goal").action == "grip_off"


def test_a_horizontal_plane_with_yaw_rotates_about_z():
    from rap.robot.inputs import load_plan_and_assembly

    plan, doc, asm = load_plan_and_assembly(TANGRAM_PLAN, TANGRAM)
    cell = with_(Cell(), "assembly", yaw_deg=90.0)
    prog = build_program(plan, asm, cell)
    fr = prog.frame
    assert fr.plane == "horizontal"
    s = prog.steps[0]
    a, b = np.array(s.waypoint("start").position), np.array(s.waypoint("goal").position)
    px, py = doc["steps"][0]["robot"]["start"]
    # a translation (px, py) of the part, rotated 90 degrees: (-py, px) in the base frame
    assert np.allclose(a - b, [-py * fr.scale_m, px * fr.scale_m, 0.0], atol=1e-12)
    assert s.waypoint("goal").position[2] == pytest.approx(cell.assembly.thickness_m)


def _doc():
    return json.loads(STACK_PLAN.read_text())


@pytest.mark.parametrize("change, words", [
    (lambda d: d["constraints"].pop("base"), "no fixture"),
    (lambda d: d["steps"][2].update(moving=["block2", "block3"], fixed=["block1", "plate"]),
     "step 3 moves {block2,block3}"),
    (lambda d: d["steps"][1].update(fixed=["block1"]), "away from the fixture"),
])
def test_a_two_handed_plan_is_refused_in_one_line(change, words, tmp_path, run_cli):
    d = copy.deepcopy(_doc())
    change(d)
    with pytest.raises(TwoHandedPlan) as err:
        from rap.io import load_assembly

        build_program(PlanResult.from_json(d), load_assembly(STACK), Cell())
    assert words in str(err.value) and "second fixture" in str(err.value)
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(d))
    code, _, out = run_cli("export", path, "--assembly", STACK, "-o", tmp_path / "p.yaml")
    assert code == 1 and words in out and len(out.strip().splitlines()) == 1
    assert not (tmp_path / "p.yaml").exists()


def test_an_unknown_assembly_is_asked_for(tmp_path, run_cli):
    path = tmp_path / "plan.json"
    path.write_text(STACK_PLAN.read_text())
    code, _, err = run_cli("export", path, "-o", tmp_path / "p.csv")
    assert code == 2 and "--assembly" in err
