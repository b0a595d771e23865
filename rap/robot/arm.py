"""The arm models rap-farm knows, and a pybullet world that holds one.

``ARM_MODELS["panda"]``: the Franka Emika Panda of ``pybullet_data`` (``franka_panda/panda.urdf``,
shipped in the pybullet wheel, Apache 2.0): 7 revolute joints within the maker's limits (the
registry's, ``rap.robot.arms.registry``, a little inside the URDF's), the fingers closed; the suction cup hangs ``gripper.tool_offset_m`` below the ``panda_grasptarget`` link
(between the fingertips), so the TCP is that far below it along the tool axis. Its base is the
cell's base frame (origin, x forward, z up).

``open_world()`` starts a pybullet physics server in DIRECT mode (no window, no GL), owned by a
``BulletClient`` so several can live in one process; ``load_arm(world, model)`` loads the arm
with a fixed base at its home pose. ``tcp_pose(world, arm, model, q)`` sets the joints (no
physics) and reads the TCP's position and orientation (forward kinematics).

Cost: about 20-40 ms to open a world and load the arm; FK a few microseconds.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from rap.robot.arms.registry import ARMS

__all__ = ["ArmModel", "ARM_MODELS", "open_world", "load_arm", "set_joints", "tcp_pose",
           "data_path"]


@dataclass(frozen=True)
class ArmModel:
    """A URDF in ``pybullet_data`` and what a check needs to know of it."""

    name: str
    urdf: str  # relative to pybullet_data
    joints: tuple[int, ...]  # the arm's joint indices, base to tip
    joint_names: tuple[str, ...]
    lower: tuple[float, ...]  # rad
    upper: tuple[float, ...]
    tcp_link: int
    home: tuple[float, ...]  # a tool-down pose above the table
    reach_m: float  # nominal reach (the maker's figure), for messages
    fixed_joints: tuple[tuple[int, float], ...] = ()  # other joints held (fingers closed)


_PANDA = ARMS["panda"]
#: the arms pybullet loads from pybullet_data (the UR arms are built from their DH rows:
#: ``rap.robot.arms.ur_model``)
ARM_MODELS = {
    "panda": ArmModel(
        name="panda", urdf=_PANDA.urdf, joints=tuple(range(7)), joint_names=_PANDA.joint_names,
        lower=_PANDA.lower, upper=_PANDA.upper, tcp_link=11, home=_PANDA.home,
        reach_m=_PANDA.reach_m, fixed_joints=((9, 0.0), (10, 0.0))),
}


def data_path() -> str:
    import pybullet_data

    return pybullet_data.getDataPath()


@contextmanager
def _quiet():
    """pybullet's C code prints its build time and argv on import and connect: send the
    process's stdout and stderr to /dev/null meanwhile (file descriptors 1 and 2 are the
    process's: another thread's output in those milliseconds is lost too)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def open_world(gravity_z: float = -9.81):
    """A new DIRECT pybullet client (``pybullet_utils.bullet_client.BulletClient``)."""
    with _quiet():
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        world = BulletClient(connection_mode=pybullet.DIRECT)
    world.setAdditionalSearchPath(data_path())
    world.setGravity(0, 0, gravity_z)
    return world


def load_arm(world, model: ArmModel) -> int:
    """Load ``model`` with a fixed base at the origin, at its home pose; its body id."""
    arm = world.loadURDF(model.urdf, basePosition=[0, 0, 0], useFixedBase=True,
                         flags=world.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT)
    set_joints(world, arm, model, model.home)
    for j, v in model.fixed_joints:
        world.resetJointState(arm, j, v)
    return arm


def set_joints(world, arm: int, model: ArmModel, q) -> None:
    for j, v in zip(model.joints, q):
        world.resetJointState(arm, j, float(v))


def tcp_pose(world, arm: int, model: ArmModel, q=None) -> tuple[np.ndarray, tuple]:
    """(position [3], quaternion xyzw) of the TCP at joints ``q`` (None: as they are)."""
    if q is not None:
        set_joints(world, arm, model, q)
    s = world.getLinkState(arm, model.tcp_link, computeForwardKinematics=True)
    return np.array(s[4]), s[5]
