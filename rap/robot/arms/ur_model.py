"""A Universal Robots arm in pybullet, built from its DH rows, and the solver that moves it.

``ur_urdf(spec)`` writes a URDF of the arm from the registry's DH rows (``rap.robot.arms.registry``:
no mesh, no file of the maker's): joint ``i`` of the URDF turns about the z of its link, whose
origin is the static part of DH row ``i - 1`` (``Tz(d) Tx(a) Rx(alpha)``), so the flange link
``tool0`` is the DH frame 6 (the tests compare its pose with ``rap.robot.arms.ur.fk``). The
links' bodies are cylinders along the DH offsets and around each joint axis, of the radii in
``LINK_RADII_M`` (the tubes and joint housings of UR's dimension drawings, rounded up to 5 mm):
a model for contacts with the parts near the tool, not the maker's shapes (the real upper arm
sits about 0.14 m along the shoulder axis, which the DH rows fold into ``d4``).

``UrSolver(spec, world, tool_offset_m, branch)`` loads it into a pybullet world (fixed base at
the origin: the cell's base frame is the UR's base frame) and offers ``IkSolver``'s interface
(``rap.robot.kinematics``) to ``rap.robot.arm_sim``: ``solve(target, seed)`` is the analytic
solution on ``branch`` nearest ``seed`` with the tool down and the TCP on ``target``.
``solver_for(program)`` is a factory of the right solver for the program's arm (the UR's branch
found once by its check). Cost: writing the URDF once a process (a few ms); a solve about 60 us.
"""

from __future__ import annotations

import math
import os
import tempfile

import numpy as np

from rap.robot.arm import ArmModel, set_joints
from rap.robot.arms import ur
from rap.robot.arms.registry import ArmSpec, arm_spec
from rap.robot.program import Program

__all__ = ["ur_urdf", "ur_model", "UrSolver", "solver_for", "LINK_RADII_M"]

#: per arm, the radius (m) of each link's body, base to wrist 3 (housing and tube)
LINK_RADII_M = {"ur5e": (0.075, 0.06, 0.045, 0.045, 0.045, 0.04),
                "ur10e": (0.095, 0.075, 0.06, 0.05, 0.05, 0.045)}
_FILES: dict[str, str] = {}


def _cylinder(a, b, r: float) -> str:
    """A URDF cylinder of radius ``r`` from point ``a`` to ``b`` (the link's frame)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    length = float(np.linalg.norm(d))
    mid = (a + b) / 2
    u = d / length
    pitch = math.acos(max(-1.0, min(1.0, u[2])))
    yaw = math.atan2(u[1], u[0])
    geo = (f'<origin xyz="{mid[0]:.6f} {mid[1]:.6f} {mid[2]:.6f}" rpy="0 {pitch:.6f} {yaw:.6f}"/>'
           f'<geometry><cylinder radius="{r}" length="{length:.6f}"/></geometry>')
    return (f"<visual>{geo}<material name=\"grey\"><color rgba=\"0.75 0.78 0.8 1\"/></material>"
            f"</visual><collision>{geo}</collision>")


def ur_urdf(spec: ArmSpec) -> str:
    """The URDF text of ``spec`` (module doc)."""
    dh, radii = spec.dh, LINK_RADII_M[spec.name]
    names = ["base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
             "wrist_2_link", "wrist_3_link"]
    out = [f'<?xml version="1.0"?>\n<robot name="{spec.name}">',
           '<link name="base_link"><inertial><mass value="4"/><inertia ixx="0.01" ixy="0" '
           'ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
           + _cylinder((0, 0, 0), (0, 0, 0.05), radii[0]) + "</link>"]
    for i in range(6):
        r = radii[i]
        d, a = dh.d[i], dh.a[i]
        body = _cylinder((0, 0, -r), (0, 0, r), r)  # the joint's housing around its axis
        if abs(d) > 1e-9:
            body += _cylinder((0, 0, 0), (0, 0, d), r * 0.9)
        if abs(a) > 1e-9:
            body += _cylinder((0, 0, d), (a, 0, d), r * 0.85)
        out.append(f'<link name="{names[i + 1]}"><inertial><mass value="1"/><inertia ixx="0.01"'
                   f' ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>{body}</link>')
        if i == 0:
            origin = '<origin xyz="0 0 0" rpy="0 0 0"/>'
        else:
            pd, pa, pal = dh.d[i - 1], dh.a[i - 1], dh.alpha[i - 1]
            origin = f'<origin xyz="{pa:.6f} 0 {pd:.6f}" rpy="{pal:.9f} 0 0"/>'
        out.append(f'<joint name="{spec.joint_names[i]}" type="revolute"><parent link='
                   f'"{names[i]}"/><child link="{names[i + 1]}"/>{origin}<axis xyz="0 0 1"/>'
                   f'<limit lower="{spec.lower[i]:.6f}" upper="{spec.upper[i]:.6f}" effort="150"'
                   f' velocity="{spec.max_velocity[i]:.4f}"/></joint>')
    out.append('<link name="tool0"><inertial><mass value="0.01"/><inertia ixx="1e-6" ixy="0" '
               'ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>')
    out.append(f'<joint name="flange" type="fixed"><parent link="wrist_3_link"/><child '
               f'link="tool0"/><origin xyz="{dh.a[5]:.6f} 0 {dh.d[5]:.6f}" '
               f'rpy="{dh.alpha[5]:.9f} 0 0"/></joint>')
    out.append("</robot>")
    return "\n".join(out) + "\n"


def ur_model(spec: ArmSpec) -> ArmModel:
    """The ``ArmModel`` (``rap.robot.arm``) of ``spec``, its URDF written once a process to a
    temporary file (an absolute path: pybullet loads it so)."""
    path = _FILES.get(spec.name)
    if path is None or not os.path.exists(path):
        fd, path = tempfile.mkstemp(prefix=f"rap-{spec.name}-", suffix=".urdf")
        with os.fdopen(fd, "w") as f:
            f.write(ur_urdf(spec))
        _FILES[spec.name] = path
    return ArmModel(name=spec.name, urdf=path, joints=tuple(range(6)),
                    joint_names=spec.joint_names, lower=spec.lower, upper=spec.upper,
                    tcp_link=6, home=spec.home, reach_m=spec.reach_m)


class UrSolver:
    """The UR's solver for ``rap.robot.arm_sim`` (module doc)."""

    def __init__(self, spec: ArmSpec, world, tool_offset_m: float, branch: ur.Branch):
        self.spec, self.branch, self.offset = spec, branch, float(tool_offset_m)
        self.model = ur_model(spec)
        self.world = world
        # no self-collision: the housings of neighbouring links overlap in this cylinder model
        self.arm = world.loadURDF(self.model.urdf, basePosition=[0, 0, 0], useFixedBase=True)
        set_joints(world, self.arm, self.model, self.model.home)

    def solve(self, target, seed) -> tuple[np.ndarray, float, float, list[int]]:
        """``(q, position error m, angle error rad, [])``: the branch's solution nearest
        ``seed``, the arm's joints set to it; ``(seed, inf, inf, [])`` when there is none."""
        pose = ur.tool_down_pose(np.asarray(target, dtype=float), self.offset)
        q = ur.on_branch(self.spec, pose, self.branch, seed)
        if q is None:
            return np.asarray(seed, dtype=float), math.inf, math.inf, []
        set_joints(self.world, self.arm, self.model, q)  # as IkSolver leaves the arm: there
        T = ur.fk(self.spec.dh, q)
        return q, float(np.linalg.norm(T[:3, 3] - pose[:3, 3])), 0.0, []

    def close(self) -> None:
        self.world.disconnect()


def solver_for(program: Program):
    """A function ``world -> solver`` for ``program``'s arm: the Panda's ``IkSolver``, or a
    ``UrSolver`` on the branch its check keeps (``Unreachable``, exit 1, when none)."""
    spec = arm_spec(program.cell.robot.arm)
    offset = program.cell.gripper.tool_offset_m
    if spec.kinematics != "dh":
        from rap.robot.kinematics import IkSolver

        return lambda world: IkSolver(spec.name, world=world, tool_offset_m=offset)
    from rap.robot.arms.ur_check import check_ur

    name = check_ur(program).branch
    branch = next(b for b in ur.BRANCHES if str(b) == name)
    return lambda world: UrSolver(spec, world, offset, branch)
