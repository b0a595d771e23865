"""The arms rap-farm programs, as data: kinematics, limits, reach, repeatability, program formats.

One ``ArmSpec`` per arm in ``ARMS`` (the names a cell file's ``[robot] arm`` takes), and the one
export vocabulary ``FORMATS`` that the CLI (``export --format``), the service (``POST /export``'s
``format``) and the page share. Each arm lists the formats it takes (``ArmSpec.formats``); an
unknown format, or one the arm does not take, is an ``InputError`` (exit 2) of one line from
``check_format``.

Sources of the figures (each arm's ``source``): Universal Robots' published DH parameters
("DH parameters for calculations of kinematics and dynamics", universal-robots.com, e-Series) and
the UR5e / UR10e data sheets (reach, repeatability per ISO 9283, joint ranges and speeds); for the
Panda, Franka Emika's "Robot and interface specifications" (joint limits, velocity, acceleration,
jerk) and data sheet (reach, repeatability). A figure the maker does not publish is ``None``.
Units: metres, radians, seconds, kilograms.

How to add an arm: add an ``ArmSpec`` here (its kinematics: DH rows, or a URDF with its licence),
the formats it takes, and its checker in ``rap.robot.arms.check`` (``docs/ROBOT.md``). Pure data,
no import beyond the standard library and ``rap.errors``; cost: none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rap.errors import InputError

__all__ = ["DH", "ArmSpec", "ExportFormat", "ARMS", "FORMATS", "DEFAULT_ARM", "arm_spec",
           "check_format", "format_for_suffix"]

_DEG = math.pi / 180.0


@dataclass(frozen=True)
class DH:
    """Standard Denavit-Hartenberg rows, base to flange: joint ``i`` turns about ``z_{i-1}`` by
    ``theta_i``, then ``d_i`` along it, ``a_i`` along the new x and ``alpha_i`` about it."""

    d: tuple[float, ...]
    a: tuple[float, ...]
    alpha: tuple[float, ...]


@dataclass(frozen=True)
class ExportFormat:
    """A program format: its name, the file name's ending after the assembly's name, the media
    type, and what it is (for help texts and the page)."""

    name: str
    ending: str
    media_type: str
    what: str


#: the one export vocabulary (CLI --format, POST /export's "format", the page's select)
FORMATS = {f.name: f for f in (
    ExportFormat("urscript", ".script", "text/plain",
                 "URScript: joint-target movej on one IK branch, movel blend 0 (UR arms)"),
    ExportFormat("joint-trajectory-yaml", "-trajectory.yaml", "application/yaml",
                 "ROS 2 trajectory_msgs/JointTrajectory segments as YAML, time-parametrized"),
    ExportFormat("joint-trajectory-json", "-trajectory.json", "application/json",
                 "ROS 2 trajectory_msgs/JointTrajectory segments as JSON, time-parametrized"),
    ExportFormat("waypoints-csv", "-waypoints.csv", "text/csv",
                 "Cartesian waypoints, one row each (any arm)"),
    ExportFormat("waypoints-json", "-waypoints.json", "application/json",
                 "Cartesian waypoints with the frame and the cell (any arm)"),
)}


@dataclass(frozen=True)
class ArmSpec:
    """One arm (module doc). Joint vectors are base to tip; ``None``: not published."""

    name: str
    title: str
    kinematics: str  # "dh" (``dh`` rows, analytic IK) or "urdf" (``urdf`` in pybullet_data)
    dh: DH | None
    urdf: str | None  # relative to pybullet_data
    licence: str  # of the kinematic model's file (a URDF), or of the published figures
    joint_names: tuple[str, ...]
    lower: tuple[float, ...]  # rad
    upper: tuple[float, ...]
    max_velocity: tuple[float, ...]  # rad/s
    max_acceleration: tuple[float, ...] | None  # rad/s^2
    max_jerk: tuple[float, ...] | None  # rad/s^3
    reach_m: float
    repeatability_m: float  # the maker's figure (ISO 9283), +/-; the grasp error model's default
    payload_kg: float
    home: tuple[float, ...]  # a tool-down pose above the table; trajectories start here
    formats: tuple[str, ...]  # the first is the arm's default
    source: str

    @property
    def dof(self) -> int:
        return len(self.joint_names)


_UR_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
              "wrist_2_joint", "wrist_3_joint")
_UR_SOURCE = ("Universal Robots: DH parameters for calculations of kinematics and dynamics "
              "(e-Series), and the {} technical specifications")
_UR_HOME = (0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0)
_FULL_TURN = (2 * math.pi,) * 6
_PANDA_LOWER = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
_PANDA_UPPER = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)

ARMS = {a.name: a for a in (
    ArmSpec(
        name="panda", title="Franka Emika Panda", kinematics="urdf", dh=None,
        urdf="franka_panda/panda.urdf", licence="Apache-2.0 (pybullet_data)",
        joint_names=tuple(f"panda_joint{i}" for i in range(1, 8)),
        lower=_PANDA_LOWER, upper=_PANDA_UPPER,
        max_velocity=(2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100),
        max_acceleration=(15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
        max_jerk=(7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0),
        reach_m=0.855, repeatability_m=0.1e-3, payload_kg=3.0,
        home=(0.0, -0.4, 0.0, -2.2, 0.0, 1.8, 0.785),
        formats=("joint-trajectory-yaml", "joint-trajectory-json", "waypoints-csv",
                 "waypoints-json"),
        source="Franka Emika: Robot and interface specifications (Franka Control Interface), "
               "Panda data sheet"),
    ArmSpec(
        name="ur5e", title="Universal Robots UR5e", kinematics="dh",
        dh=DH(d=(0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996),
              a=(0.0, -0.425, -0.3922, 0.0, 0.0, 0.0),
              alpha=(math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)),
        urdf=None, licence="published figures (Universal Robots)", joint_names=_UR_JOINTS,
        lower=tuple(-v for v in _FULL_TURN), upper=_FULL_TURN,
        max_velocity=(180 * _DEG,) * 6, max_acceleration=None, max_jerk=None,
        reach_m=0.85, repeatability_m=0.03e-3, payload_kg=5.0, home=_UR_HOME,
        formats=("urscript", "waypoints-csv", "waypoints-json"),
        source=_UR_SOURCE.format("UR5e")),
    ArmSpec(
        name="ur10e", title="Universal Robots UR10e", kinematics="dh",
        dh=DH(d=(0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655),
              a=(0.0, -0.6127, -0.57155, 0.0, 0.0, 0.0),
              alpha=(math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)),
        urdf=None, licence="published figures (Universal Robots)", joint_names=_UR_JOINTS,
        lower=tuple(-v for v in _FULL_TURN), upper=_FULL_TURN,
        max_velocity=(120 * _DEG, 120 * _DEG, 180 * _DEG, 180 * _DEG, 180 * _DEG, 180 * _DEG),
        max_acceleration=None, max_jerk=None,
        reach_m=1.3, repeatability_m=0.05e-3, payload_kg=12.5, home=_UR_HOME,
        formats=("urscript", "waypoints-csv", "waypoints-json"),
        source=_UR_SOURCE.format("UR10e")),
)}
DEFAULT_ARM = "panda"

_SUFFIXES = {".script": "urscript", ".urscript": "urscript", ".csv": "waypoints-csv",
             ".json": "waypoints-json", ".yaml": "joint-trajectory-yaml",
             ".yml": "joint-trajectory-yaml"}


def arm_spec(name: str, where: str = "arm") -> ArmSpec:
    """The arm called ``name``; an ``InputError`` (one line naming ``where``, exit 2) for an
    unknown one."""
    if name not in ARMS:
        raise InputError(f"{where} {name!r}: unknown (known: {', '.join(ARMS)})")
    return ARMS[name]


def check_format(arm: str, fmt: str, where: str = "format") -> str:
    """``fmt`` when ``arm`` takes it; else an ``InputError`` (one line, exit 2) naming the formats
    the arm takes (``where`` names the option: ``--format``, ``format``)."""
    spec = arm_spec(arm)
    if fmt not in FORMATS:
        raise InputError(f"{where} {fmt!r}: unknown (choose one of {', '.join(FORMATS)})")
    if fmt not in spec.formats:
        raise InputError(f"{where} {fmt!r}: the {spec.name} ({spec.title}) does not take it; it "
                         f"takes {', '.join(spec.formats)}")
    return fmt


def format_for_suffix(arm: str, suffix: str) -> str:
    """The format a file name's suffix implies for ``arm`` (``.script`` URScript, ``.csv`` and
    ``.json`` waypoints, ``.yaml`` a joint trajectory); the arm's default format otherwise."""
    return _SUFFIXES.get(suffix.lower(), arm_spec(arm).formats[0])
