"""The robot cell: where the arm, the table, the assembly and the tray are, read from a TOML file.

``Cell()`` is the shipped cell; ``rap/robot/default_cell.toml`` writes the same values out with a
comment per key (``tests/robot/test_cell.py`` checks that they agree) and is the template a user
copies. ``load_cell(path)`` reads a cell file with ``tomllib`` (``cell_from_toml(text)`` its
text, as the service's ``POST /export`` gets it): every key is optional (a missing one keeps the
default), an unknown section or key, a value of the wrong type or out of range is a ``CellError``
(an ``InputError``: exit status 2) of one line naming the file and the key, e.g.
``cell.toml: motion.insertion_speed_m_s: expected a number > 0, got -1``.

Units: metres, degrees, seconds; the robot's base frame (x forward, y left, z up). Pure Python,
no third-party import; cost: one TOML parse.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

from rap.errors import InputError
from rap.execution.error_model import DEFAULT_ERRORS, ErrorModel
from rap.robot.arms.registry import ARMS as ARM_REGISTRY

__all__ = ["Cell", "CellError", "ArmSection", "AssemblySection", "TableSection",
           "GripperSection", "TraySection", "MotionSection", "ErrorsSection", "load_cell", "cell_from_toml",
           "parse_cell", "DEFAULT_CELL_FILE", "ARMS", "PLANES", "UNIT_METRES", "with_"]

DEFAULT_CELL_FILE = Path(__file__).with_name("default_cell.toml")
ARMS = tuple(ARM_REGISTRY)  # [robot] arm names one of rap.robot.arms.registry.ARMS
PLANES = ("auto", "vertical", "horizontal")
GRIPPERS = ("suction",)
#: metres per unit of the assembly units that rap-farm knows (``Assembly.units``)
UNIT_METRES = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254, "inch": 0.0254, "um": 1e-6}


class CellError(InputError):
    """A cell file that cannot be used: one line naming the file and the key. Exit status 2."""


@dataclass(frozen=True)
class ArmSection:
    arm: str = "panda"


@dataclass(frozen=True)
class AssemblySection:
    plane: str = "auto"
    position_m: tuple[float, float] = (0.5, 0.0)
    yaw_deg: float = 0.0
    unit_m: float = 0.002
    thickness_m: float = 0.02
    density_kg_m3: float = 700.0  # the parts' material: their mass, the payload a program sets


@dataclass(frozen=True)
class TableSection:
    height_m: float = 0.0


@dataclass(frozen=True)
class GripperSection:
    kind: str = "suction"
    cup_diameter_m: float = 0.012
    tool_offset_m: float = 0.04
    output: int = 0
    mass_kg: float = 0.1  # the cup and its mount: the payload without a part


@dataclass(frozen=True)
class TraySection:
    origin_m: tuple[float, float] = (0.35, 0.3)
    spacing_m: float = 0.02
    columns: int = 0
    slots: tuple[tuple[str, tuple[float, float]], ...] = ()  # (part id, (x, y)) given

    def slot_of(self, part: str) -> tuple[float, float] | None:
        return dict(self.slots).get(part)


@dataclass(frozen=True)
class MotionSection:
    """``[motion]``: how the arm moves between and along the program's waypoints."""

    approach_height_m: float = 0.05  # above the placed parts before descending
    joint_speed_rad_s: float = 1.0  # movej
    joint_acceleration_rad_s2: float = 1.4
    linear_speed_m_s: float = 0.25  # movel, in free space
    insertion_speed_m_s: float = 0.02  # movel, the insertion itself
    linear_acceleration_m_s2: float = 0.5
    samples_per_segment: int = 8  # points checked along each straight segment


@dataclass(frozen=True)
class ErrorsSection:
    """The cell's error model (``rap.execution.error_model``): the grasp's error across and along
    the insertion and its angle, and the arm's repeatability (None: the arm's figure from the
    registry)."""

    grasp_across_mm: float = DEFAULT_ERRORS.grasp_across_mm
    grasp_along_mm: float = DEFAULT_ERRORS.grasp_along_mm
    grasp_angle_deg: float = DEFAULT_ERRORS.grasp_angle_deg
    repeatability_mm: float | None = None
    force_noise: bool = True


@dataclass(frozen=True)
class Cell:
    """A robot cell (module doc); ``Cell()`` is the shipped one. ``source``: the file it came from
    (``"default cell"`` for the shipped one), used in messages."""

    robot: ArmSection = field(default_factory=ArmSection)
    assembly: AssemblySection = field(default_factory=AssemblySection)
    table: TableSection = field(default_factory=TableSection)
    gripper: GripperSection = field(default_factory=GripperSection)
    tray: TraySection = field(default_factory=TraySection)
    motion: MotionSection = field(default_factory=MotionSection)
    errors: ErrorsSection = field(default_factory=ErrorsSection)
    source: str = "default cell"

    def to_dict(self) -> dict:
        """The cell as plain data (the TOML's sections), for reports."""
        out = {}
        for f in fields(self):
            if f.name == "source":
                continue
            sec = getattr(self, f.name)
            out[f.name] = {g.name: (dict(sec.slots) if g.name == "slots" else
                                    list(v) if isinstance(v := getattr(sec, g.name), tuple)
                                    else v) for g in fields(sec)}
        return out

    def error_model(self) -> ErrorModel:
        """The cell's ``[errors]`` as an ``ErrorModel``: the arm's repeatability (the maker's
        figure, ``rap.robot.arms.registry``) unless the cell sets its own."""
        e = self.errors
        rep = e.repeatability_mm
        if rep is None:
            rep = round(ARM_REGISTRY[self.robot.arm].repeatability_m * 1000.0, 9)
        return ErrorModel(e.grasp_across_mm, e.grasp_along_mm, e.grasp_angle_deg, rep,
                          e.force_noise)

    def unit_metres(self, units: str) -> float:
        """Metres per unit of an assembly in ``units`` (``assembly.unit_m`` for unknown ones)."""
        return UNIT_METRES.get(str(units).lower(), self.assembly.unit_m)


def _number(where, v, *, positive=False, at_least=None):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise CellError(f"{where}: expected a number, got {v!r}")
    if positive and not v > 0:
        raise CellError(f"{where}: expected a number > 0, got {v!r}")
    if at_least is not None and v < at_least:
        raise CellError(f"{where}: expected a number >= {at_least}, got {v!r}")
    return float(v)


def _integer(where, v, low, high):
    if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
        raise CellError(f"{where}: expected an integer in {low}..{high}, got {v!r}")
    return v


def _choice(where, v, allowed):
    if v not in allowed:
        raise CellError(f"{where}: expected one of {', '.join(allowed)}, got {v!r}")
    return v


def _xy(where, v):
    if not isinstance(v, list) or len(v) != 2:
        raise CellError(f"{where}: expected [x, y] in metres, got {v!r}")
    return (_number(where, v[0]), _number(where, v[1]))


def _slots(where, v):
    if not isinstance(v, dict):
        raise CellError(f"{where}: expected a table of part id = [x, y], got {v!r}")
    return tuple(sorted((str(k), _xy(f"{where}.{k}", xy)) for k, xy in v.items()))


_POSITIVE = {"unit_m", "thickness_m", "density_kg_m3", "mass_kg", "cup_diameter_m", "tool_offset_m", "spacing_m",
             "approach_height_m",
             "joint_speed_rad_s", "joint_acceleration_rad_s2", "linear_speed_m_s",
             "insertion_speed_m_s", "linear_acceleration_m_s2"}
_CHECKS = {
    "arm": lambda w, v: _choice(w, v, ARMS),
    "plane": lambda w, v: _choice(w, v, PLANES),
    "kind": lambda w, v: _choice(w, v, GRIPPERS),
    "position_m": _xy, "origin_m": _xy, "slots": _slots,
    "output": lambda w, v: _integer(w, v, 0, 7),
    "columns": lambda w, v: _integer(w, v, 0, 1000),
    "samples_per_segment": lambda w, v: _integer(w, v, 2, 1000),
    "yaw_deg": _number, "height_m": _number,
    "force_noise": lambda w, v: v if isinstance(v, bool) else _choice(w, v, ("true", "false")),
    **{k: (lambda w, v: _number(w, v, at_least=0.0))
       for k in ("grasp_across_mm", "grasp_along_mm", "grasp_angle_deg", "repeatability_mm")},
}


def _value(where: str, key: str, v):
    if key in _POSITIVE:
        return _number(where, v, positive=True)
    return _CHECKS[key](where, v)


def parse_cell(doc: dict, source: str = "cell") -> Cell:
    """The cell described by a parsed TOML document (module doc); ``source`` names it in errors."""
    kwargs = {}
    sections = {f.name: f for f in fields(Cell) if f.name != "source"}
    for name, body in doc.items():
        if name not in sections:
            raise CellError(f"{source}: [{name}]: unknown section (known: {', '.join(sections)})")
        if not isinstance(body, dict):
            raise CellError(f"{source}: {name}: expected a [{name}] table, got {body!r}")
        cls = sections[name].default_factory  # type: ignore[misc]
        known = {g.name for g in fields(cls)}
        values = {}
        for key, v in body.items():
            if key not in known:
                raise CellError(f"{source}: {name}.{key}: unknown key (known: "
                                f"{', '.join(sorted(known))})")
            values[key] = _value(f"{source}: {name}.{key}", key, v)
        kwargs[name] = cls(**values)
    return Cell(**kwargs, source=source)


def load_cell(path: str | Path | None = None) -> Cell:
    """The cell in the TOML file ``path`` (None: the shipped ``Cell()``). Raises ``CellError``
    (exit 2) for a missing or unreadable file, bad TOML, or a bad key (module doc)."""
    if path is None:
        return Cell()
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CellError(f"{path}: cannot read the cell file ({getattr(exc, 'strerror', None) or exc})"
                        ) from None
    return cell_from_toml(text, str(path))


def cell_from_toml(text: str, source: str = "cell") -> Cell:
    """The cell described by a cell file's TOML ``text``; ``source`` names it in errors. Raises
    ``CellError`` for bad TOML or a bad key (module doc)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CellError(f"{source}: not a TOML file ({exc})") from None
    return parse_cell(doc, source)


def with_(cell: Cell, section: str, **changes) -> Cell:
    """``cell`` with some keys of one section changed (tests, benchmarks)."""
    return replace(cell, **{section: replace(getattr(cell, section), **changes)})
