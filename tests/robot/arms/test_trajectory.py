"""The Panda's trajectory: within its velocity, acceleration and jerk limits at every sample, from
home, at rest where the vacuum switches, through every checked joint vector; its ROS 2 files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rap.robot.arms.registry import ARMS
from rap.robot.arms.ros import trajectory_document, trajectory_json, trajectory_yaml
from rap.robot.arms.trajectory import limit_ratios, plan_trajectory, sample
from rap.robot.cell import Cell
from rap.robot.kinematics import check_program
from rap.robot.program import build_program


@pytest.fixture(scope="module")
def panda():
    from rap.robot.inputs import load_plan_and_assembly

    from tests.robot.cases import STACK, STACK_PLAN

    plan, _, asm = load_plan_and_assembly(STACK_PLAN, STACK)
    prog = build_program(plan, asm, Cell())
    report = check_program(prog)
    return prog, report, plan_trajectory(prog, report)


def test_the_trajectory_respects_the_pandas_limits(panda):
    _, _, traj = panda
    v, a, j = limit_ratios(traj, dt_s=0.001)
    assert 0 < v <= 1 and 0 < a <= 1 and 0 < j <= 1, (v, a, j)


def test_it_starts_home_stops_at_each_switch_and_passes_every_checked_pose(panda):
    prog, report, traj = panda
    spec = ARMS["panda"]
    assert [s.action for s in traj.segments] == ["grip_on", "grip_off"] * 3 + [""]  # retreat
    t, q, qd, qdd, _ = sample(traj.segments[0], 0.01)
    assert np.allclose(q[0], spec.home) and t[0] == 0
    for seg in traj.segments:
        t, q, qd, qdd, _ = sample(seg, 0.01)
        assert np.abs(qd[[0, -1]]).max() < 1e-9 and np.abs(qdd[[0, -1]]).max() < 1e-9
        assert (np.diff(t) > 0).all()
    # each move ends on its waypoint's checked joint vector
    ends = [m.spline.eval([m.length])[0][0] for s in traj.segments for m in s.moves]
    assert np.abs(np.array(ends) - np.array(report.joints)).max() < 1e-9


def test_the_ros2_documents(panda):
    prog, _, traj = panda
    doc = json.loads(trajectory_json(prog, traj))
    assert doc == json.loads(json.dumps(trajectory_document(prog, traj)))
    seg = doc["segments"][0]
    assert seg["then"] == "grip_on" and seg["trajectory"]["joint_names"][0] == "panda_joint1"
    p = seg["trajectory"]["points"]
    assert set(p[0]) == {"positions", "velocities", "accelerations", "time_from_start"}
    stamps = [q["time_from_start"]["sec"] + q["time_from_start"]["nanosec"] * 1e-9 for q in p]
    assert stamps[0] == 0 and 0 < min(np.diff(stamps)) and max(np.diff(stamps)) <= 0.02 + 1e-9
    yaml = pytest.importorskip("yaml")
    assert yaml.safe_load(trajectory_yaml(prog, traj)) == doc


def test_export_writes_the_trajectory(tmp_path, run_cli):
    from tests.robot.cases import STACK, STACK_PLAN

    out = tmp_path / "p.yaml"
    code, text, _ = run_cli("export", STACK_PLAN, "--assembly", STACK, "-o", out)
    assert code == 0 and "joint-trajectory-yaml" in text and "reached by the panda" in text
    assert out.read_text().startswith("# rap-farm joint trajectory")
