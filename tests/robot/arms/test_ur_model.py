"""The UR5e in pybullet, built from its DH rows: its flange is the DH frame 6; it builds the stack
with no arm-part contact."""

from __future__ import annotations

import numpy as np

from rap.robot.arm import open_world, tcp_pose
from rap.robot.arm_sim import run_arm
from rap.robot.arms import ur
from rap.robot.arms.registry import ARMS
from rap.robot.arms.ur_model import UrSolver
from rap.robot.cell import Cell, with_
from rap.robot.program import build_program


def test_the_pybullet_flange_is_the_dh_flange():
    spec = ARMS["ur10e"]
    solver = UrSolver(spec, open_world(), 0.0, ur.BRANCHES[0])
    try:
        for q in np.random.default_rng(2).uniform(-3, 3, (20, 6)):
            pos, orn = tcp_pose(solver.world, solver.arm, solver.model, q)
            T = ur.fk(spec.dh, q)
            R = np.array(solver.world.getMatrixFromQuaternion(orn)).reshape(3, 3)
            assert np.abs(pos - T[:3, 3]).max() < 1e-5 and np.abs(R - T[:3, :3]).max() < 1e-5
        q, err, _, _ = solver.solve([0.5, 0.1, 0.2], spec.home)
        assert err < 1e-9 and ur.branch_of(spec.dh, q) == ur.BRANCHES[0]
    finally:
        solver.close()


def test_the_ur5e_builds_the_stack(stack):
    plan, _, asm = stack
    out = run_arm(build_program(plan, asm, with_(Cell(), "robot", arm="ur5e")), asm, trials=1)
    assert out.success.successes == 1
    assert [(c.reached, c.inserted, c.arm_contacts) for c in out.steps] == [(1, 1, 0)] * 3
