"""Robot-cell constraints on assembly operations: a fixture, one arm, allowed directions, gravity.

``CellConstraints`` says how the cell that executes a plan works; ``PlanningProblem.candidates``
applies it (``rap.plan.cell.rules``), so every planner obeys it. The rules, for an operation that joins
``moving`` to ``fixed`` into the subassembly ``S``:

* ``base`` (``--base PART``): the part is in the fixture from the start and never moves: when
  ``S`` holds the base, the base is on the fixed side. Subassemblies without the base may be
  built beside the fixture (without gravity), unless ``linear`` or ``gravity`` forbid it.
* ``linear`` (``--linear``): one arm, one part at a time: ``moving`` is a single part.
* ``directions`` (``--directions DX,DY:DEG``, repeatable): the insertion direction (the way
  ``moving`` travels to its place; removal = -insertion) lies within ``DEG`` degrees of ``(DX,
  DY)`` for one of the cones (their union; 0 <= DEG <= 180). The direction is chosen in the middle
  of the cones' exact intersection with the partition's direction range
  (``rap.geometry.cones``: cone edges are rational rays rounded inward, less than 1e-7 degrees
  inside the exact cone; 90 degrees is the exact closed half-plane, 180 the whole circle). Where
  the cones hold the whole range, the operation keeps its own direction.
* ``gravity`` (``--gravity DX,DY``, needs ``base``): every intermediate assembly (each
  operation's fixed side, and the whole assembly) holds the base and is statically stable under
  gravity along ``(DX, DY)`` with Coulomb friction ``friction`` at its contacts
  (``rap.sim.statics``, a linear program over contact forces). A subassembly of two or more parts
  without the base has nothing to stand on, so it cannot be built: every operation moves a single
  part into an assembly standing on the base.
* ``layers`` (``--layers``, needs ``gravity``): build in layers along gravity: a part goes in only
  after every part lying wholly below it (its highest point at most the other's lowest, heights
  measured exactly along ``-gravity``): a wall course by course. Stability alone allows any order
  in which each part goes in after what it rests on (a brick of the second course as soon as the
  bricks under it are in); masonry and stacking cells often want the layers.

Robustness scores keep the simulator and model without gravity: a step's score is the success
rate of the insertion motion under actuation noise with the parts lying flat; it does not cover
tipping, sliding or the arm's reach (``SCORE_NOTE``, in the plan's ``stats`` with the constraints).

``CellConstraints.parse(...)`` reads the flags' text, ``from_json``/``to_json`` the service's
``"constraints"`` object (``{"base": "plate", "linear": true, "directions": ["0,-1:30"],
"gravity": "0,-1", "friction": 0.5, "layers": true}``); both raise ``rap.errors.ParameterError`` naming the
parameter (``base``, ``directions``, ``gravity``, ``friction``, ``layers``). ``check(assembly)`` checks that
the base part exists. Numbers are decimals or fractions of at most ``MAX_NUMBER_CHARS``
characters, read exactly; at most ``MAX_CONES`` cones. No ray, no torch.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Iterable, Sequence

from rap.assembly import decimal_places
from rap.errors import ParameterError
from rap.geometry.cones import Arc, cone_arc

__all__ = ["Cone", "CellConstraints", "SCORE_NOTE", "MAX_NUMBER_CHARS", "MAX_CONES",
           "vector_text"]

MAX_NUMBER_CHARS = 32
MAX_CONES = 16  # --directions given at most this often (the intersection costs O(cones^2))
SCORE_NOTE = ("robustness scores come from the simulator without gravity (parts lying flat): "
              "they cover the insertion motion under actuation noise, not tipping, sliding or "
              "the arm's reach")
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:/\d+)?")


def _number(text: str, parameter: str, whole: str) -> Fraction:
    t = text.strip()
    if len(t) > MAX_NUMBER_CHARS or not _NUMBER.fullmatch(t):
        raise ParameterError(parameter, whole, f"{t!r} is not a number (e.g. 0, -1, 0.5)")
    num, _, den = t.partition("/")
    if den and int(den) == 0:
        raise ParameterError(parameter, whole, "division by zero")
    return Fraction(num) / (Fraction(den) if den else 1)


def _vector(text, parameter: str) -> tuple[Fraction, Fraction]:
    if not isinstance(text, str):
        raise ParameterError(parameter, text, "expected text DX,DY, e.g. 0,-1")
    parts = text.split(",")
    if len(parts) != 2:
        raise ParameterError(parameter, text, "expected DX,DY, e.g. 0,-1")
    v = (_number(parts[0], parameter, text), _number(parts[1], parameter, text))
    if v == (0, 0):
        raise ParameterError(parameter, text, "the direction must not be zero")
    return v


def _text(x: Fraction) -> str:
    """Exact text of a rational: a decimal when one exists, else ``n/d``."""
    x = Fraction(x)
    if x.denominator == 1:
        return str(x.numerator)
    k = decimal_places(x)
    if k is None:
        return f"{x.numerator}/{x.denominator}"
    m = abs(x.numerator) * 10 ** k // x.denominator
    digits = str(m).rjust(k + 1, "0")
    return ("-" if x < 0 else "") + (digits[:-k] + "." + digits[-k:]).rstrip("0")


def vector_text(v: Sequence) -> str:
    """``DX,DY`` of an exact vector, as the flags take it: ``0,-1``, ``1,0.5``."""
    return f"{_text(v[0])},{_text(v[1])}"


def _deg_text(x: float) -> str:
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


@dataclass(frozen=True)
class Cone:
    """Allowed INSERTION directions: within ``half_angle_deg`` of ``axis`` (0..180 degrees)."""

    axis: tuple[Fraction, Fraction]
    half_angle_deg: float

    def __post_init__(self):
        if Fraction(self.axis[0]) == 0 and Fraction(self.axis[1]) == 0:
            raise ParameterError("directions", self.text(), "the axis must not be zero")
        if not (math.isfinite(self.half_angle_deg) and 0.0 <= self.half_angle_deg <= 180.0):
            raise ParameterError("directions", self.text(), "choose 0 <= DEG <= 180 degrees")

    @classmethod
    def parse(cls, text) -> "Cone":
        """``DX,DY:DEG`` (e.g. ``0,-1:30``); ``ParameterError`` for parameter ``directions``."""
        if not isinstance(text, str) or text.count(":") != 1:
            raise ParameterError("directions", text, "expected DX,DY:DEG, e.g. 0,-1:30 (within "
                                 "30 degrees of straight down)")
        vec, deg = text.split(":")
        axis = _vector(vec, "directions")
        d = _number(deg, "directions", text)
        if not 0 <= d <= 180:
            raise ParameterError("directions", text, "choose 0 <= DEG <= 180 degrees")
        return cls(axis, float(d))

    def text(self) -> str:
        return f"{vector_text(self.axis)}:{_deg_text(self.half_angle_deg)}"

    def removal_arc(self) -> Arc:
        """The cone's REMOVAL directions (around -axis), as an exact closed ``Arc``."""
        return cone_arc((-Fraction(self.axis[0]), -Fraction(self.axis[1])), self.half_angle_deg)

    def describe(self) -> str:
        return f"{_deg_text(self.half_angle_deg)}° of ({vector_text(self.axis)})"


@dataclass(frozen=True)
class CellConstraints:
    """The cell's rules (module doc); the default constrains nothing (``active`` False)."""

    base: str | None = None
    linear: bool = False
    directions: tuple[Cone, ...] = ()
    gravity: tuple[Fraction, Fraction] | None = None
    friction: float = 0.5
    layers: bool = False

    def __post_init__(self):
        if self.gravity is not None and self.base is None:
            raise ParameterError("gravity", vector_text(self.gravity), "needs a base part "
                                 "(--base PART): the assembly stands on it", quote=False)
        if self.gravity is not None and tuple(self.gravity) == (0, 0):
            raise ParameterError("gravity", "0,0", "the direction must not be zero", quote=False)
        f = self.friction
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not math.isfinite(f) or f < 0:
            raise ParameterError("friction", f, "choose a friction coefficient >= 0")
        if self.layers and self.gravity is None:
            raise ParameterError("layers", True, "needs --gravity DX,DY (layers are stacked "
                                 "against gravity)", quote=False)

    @property
    def one_part(self) -> bool:
        """Every step moves one part (``linear``, or ``gravity``: nothing else can stand)."""
        return self.linear or self.gravity is not None

    @property
    def active(self) -> bool:
        return bool(self.base is not None or self.linear or self.directions
                    or self.gravity is not None)

    @classmethod
    def parse(cls, base: str | None = None, linear: bool = False,
              directions: Iterable[str] | None = None, gravity: str | None = None,
              friction: float | None = None, layers: bool = False) -> "CellConstraints":
        """The constraints of the flags' text (None: not given); ``ParameterError`` naming the
        parameter (``base``, ``directions``, ``gravity``, ``friction``, ``layers``)."""
        if base is not None and (not isinstance(base, str) or not base):
            raise ParameterError("base", base, "name a part of the assembly")
        directions = list(directions or ())
        if len(directions) > MAX_CONES:
            raise ParameterError("directions", len(directions), f"at most {MAX_CONES} cones",
                                 quote=False)
        cones = tuple(Cone.parse(t) for t in directions)
        g = None if gravity is None else _vector(gravity, "gravity")
        if friction is not None and g is None:
            raise ParameterError("friction", friction, "applies only with --gravity")
        if friction is not None and (isinstance(friction, bool)
                                     or not isinstance(friction, (int, float))):
            raise ParameterError("friction", friction, "choose a friction coefficient >= 0")
        return cls(base, bool(linear), cones, g, 0.5 if friction is None else float(friction),
                   bool(layers))

    def check(self, assembly) -> "CellConstraints":
        """``self`` when its base is a part of ``assembly``; else ``ParameterError`` (``base``)."""
        if self.base is not None and self.base not in assembly.ids:
            shown = ", ".join(list(assembly.ids)[:12]) + (" ..." if len(assembly) > 12 else "")
            raise ParameterError("base", self.base, f"no such part in {assembly.name} "
                                 f"(parts: {shown})", quote=False)
        return self

    def relaxed(self, rule: str) -> "CellConstraints":
        """Without one rule (``base`` also drops ``gravity``, and ``gravity`` ``layers``, which
        need them)."""
        if rule == "base":
            return replace(self, base=None, gravity=None, layers=False)
        if rule == "gravity":
            return replace(self, gravity=None, layers=False)
        if rule == "layers":
            return replace(self, layers=False)
        if rule == "directions":
            return replace(self, directions=())
        if rule == "linear":
            return replace(self, linear=False)
        raise ValueError(f"no rule {rule!r}")

    def rules(self) -> tuple[str, ...]:
        """The active rules, in the order a blocker is looked for."""
        return tuple(r for r, on in (("layers", self.layers),
                                     ("gravity", self.gravity is not None),
                                     ("directions", bool(self.directions)),
                                     ("linear", self.linear), ("base", self.base is not None))
                     if on)

    def flag(self, rule: str) -> str:
        """A rule as its flag and value: ``--gravity 0,-1``, ``--directions 0,-1:30``."""
        if rule == "gravity":
            return f"--gravity {vector_text(self.gravity)}"
        if rule == "directions":
            return " ".join(f"--directions {c.text()}" for c in self.directions)
        if rule == "linear":
            return "--linear"
        if rule == "layers":
            return "--layers"
        return f"--base {self.base}"

    def gravity_unit(self) -> tuple[float, float]:
        gx, gy = float(self.gravity[0]), float(self.gravity[1])
        n = math.hypot(gx, gy)
        return (gx / n, gy / n)

    def removal_arcs(self) -> list[Arc]:
        return [c.removal_arc() for c in self.directions]

    def describe(self) -> str:
        """The constraints in words, one line (``no cell constraints`` when inactive)."""
        out = []
        if self.base is not None:
            out.append(f"{self.base} fixed in the fixture")
        if self.linear:
            out.append("one part per step")
        if self.directions:
            out.append("insertion within " + " or ".join(c.describe() for c in self.directions))
        if self.gravity is not None:
            out.append(f"stable under gravity ({vector_text(self.gravity)}), friction "
                       f"{self.friction:g}")
        if self.layers:
            out.append("in layers against gravity")
        return "; ".join(out) if out else "no cell constraints"

    def to_json(self) -> dict:
        """The service's ``"constraints"`` object (``from_json`` reads it back)."""
        return {"base": self.base, "linear": self.linear,
                "directions": [c.text() for c in self.directions],
                "gravity": None if self.gravity is None else vector_text(self.gravity),
                "friction": self.friction, "layers": self.layers}

    @classmethod
    def from_json(cls, doc) -> "CellConstraints":
        """The constraints of a ``to_json`` object (keys optional; unknown keys refused);
        ``ParameterError`` naming the key."""
        if not isinstance(doc, dict):
            raise ParameterError("constraints", doc, "must be an object with base, linear, "
                                 "directions, gravity, friction, layers")
        known = ("base", "linear", "directions", "gravity", "friction", "layers")
        for key in doc:
            if key not in known:
                raise ParameterError("constraints", key, f"unknown key (expected "
                                     f"{', '.join(known)})")
        linear, layers = doc.get("linear", False), doc.get("layers", False)
        for key, value in (("linear", linear), ("layers", layers)):
            if not isinstance(value, bool):
                raise ParameterError(key, value, "must be true or false")
        directions = doc.get("directions") or []
        if not isinstance(directions, list):
            raise ParameterError("directions", directions, "must be a list of \"DX,DY:DEG\"")
        friction = doc.get("friction")
        if friction is not None and not isinstance(friction, bool):
            try:
                friction = float(friction)
            except (TypeError, ValueError):
                raise ParameterError("friction", friction, "choose a number >= 0") from None
        if friction is not None and doc.get("gravity") is None and friction == 0.5:
            friction = None  # to_json writes the default friction without gravity
        return cls.parse(doc.get("base"), linear, directions, doc.get("gravity"), friction,
                         layers)
