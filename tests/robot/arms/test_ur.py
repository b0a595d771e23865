"""UR kinematics: the maker's FK vector, our DH FK against ur-analytic-ik's, the IK round trip on
10,000 seeded poses, and branches that survive 2 pi turns."""

from __future__ import annotations

import numpy as np
import pytest

from rap.robot.arms import ur
from rap.robot.arms.registry import ARMS


def test_ur5e_at_zero_puts_the_flange_at_the_makers_vector():
    T = ur.fk(ARMS["ur5e"].dh, np.zeros(6))
    assert np.abs(T[:3, 3] - [-0.8172, -0.2329, 0.0628]).max() < 1e-4


@pytest.mark.parametrize("name", ["ur5e", "ur10e"])
def test_our_fk_is_the_ik_packages_fk(name):
    import ur_analytic_ik

    q = np.random.default_rng(5).uniform(-np.pi, np.pi, (200, 6))
    ours = ur.fk(ARMS[name].dh, q)
    theirs = np.array([getattr(ur_analytic_ik, name).forward_kinematics(*v) for v in q])
    assert np.abs(ours - theirs).max() < 1e-9


@pytest.mark.parametrize("name", ["ur5e", "ur10e"])
def test_ik_round_trip_on_10000_seeded_poses(name):
    spec = ARMS[name]
    q = np.random.default_rng(47).uniform(-np.pi, np.pi, (10_000, 6))
    T = ur.fk(spec.dh, q)
    sols = ur.solutions(spec, T)  # (N, 8, 6), NaN off-branch
    found = ~np.isnan(sols[..., 0])
    back = ur.fk(spec.dh, np.nan_to_num(sols))
    pos = np.linalg.norm(back[..., :3, 3] - T[:, None, :3, 3], axis=-1)[found]
    rot = np.abs(back[..., :3, :3] - T[:, None, :3, :3]).max(axis=(-1, -2))[found]
    assert pos.max() < 1e-6 and rot.max() < 1e-6
    # the sampled joint vector is among the solutions, on its own branch
    codes = ur.branch_codes(spec.dh, q)
    b = (1 - codes[:, 0]) * 2 + (1 - codes[:, 1]) + (codes[:, 2] + 1) // 2
    own = sols[np.arange(len(q)), b]
    assert not np.isnan(own).any()
    assert np.abs(np.angle(np.exp(1j * (own - q)))).max() < 1e-6


def test_branches_are_geometric_and_all_eight_appear():
    spec = ARMS["ur5e"]
    pose = ur.tool_down_pose([0.5, 0.0, 0.1], 0.04)
    sols = ur.solutions(spec, pose[None])[0]
    assert not np.isnan(sols).any()  # 8 distinct branches
    for b, q in zip(ur.BRANCHES, sols):
        assert ur.branch_of(spec.dh, q) == b == ur.branch_of(spec.dh, q + 2 * np.pi)
    # tool down keeps the wrist far from its singularity (axes 4 and 6 at right angles)
    assert np.allclose(ur.margins(spec.dh, sols)[:, 0], 1.0)
    near = sols[0] + 0.01
    assert np.allclose(ur.on_branch(spec, pose, ur.BRANCHES[0], near), sols[0])
    assert ur.solutions(spec, ur.tool_down_pose([3.0, 0, 0.1])[None]).shape == (1, 8, 6)
    assert np.isnan(ur.solutions(spec, ur.tool_down_pose([3.0, 0, 0.1])[None])).all()
