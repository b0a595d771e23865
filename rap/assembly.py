"""Assemblies: planar polygonal parts in their final placements, exact, and their file format.

An assembly file is JSON::

    {"name": "optional", "units": "optional, e.g. mm", "parts": [{"id": "a", "polygon": [[x, y], ...],
                                    "holes": [[[x, y], ...], ...]}]}

``units`` names the unit of the coordinates (``rap-farm import`` writes the drawing's output unit,
e.g. ``"mm"``); without it ``DEFAULT_UNITS`` (``"unit"``: the drawing's units, whatever they are).
Like the name, it is metadata: not part of the geometry hash. Plans state it (``rap.plan.report.poses``).

Coordinates are ``fractions.Fraction`` (read from the file's decimals, never through a binary
float), so shared edges and touching contacts stay exact. Rings are normalised: outer boundaries
counter-clockwise, holes clockwise. ``assembly_to_json`` writes the document back exactly.

**Input bounds** (``LIMITS``, an ``InputLimits``), checked while reading
(``rap.assembly_reader``), before any geometry: every coordinate is a decimal with
``|x| <= 10^9`` and at most 6 digits after the point (so ``x * 10^6`` is an integer of at most
10^15 < 2^53), a ring has at most 10,000 vertices, a part at most 100 holes, an assembly at most
1,000 parts and 100,000 vertices in all, an id at most 100 characters, a file at most 16 MiB.
What they guarantee downstream: the exact layer scales by at most 10^6
(``rap.geometry.exact.to_integers``) and its predicates multiply integers of at most 51 bits
(products under 2^104: constant-time machine-word-sized big ints, never million-digit ones);
every coordinate and every difference of two is a float without overflow, distinct points stay
distinct as floats (the physics and the renderer convert them).

This module holds the data, its bounds and its JSON document; reading untrusted JSON exactly is
``rap.assembly_reader`` (``read_assembly_json``, ``assembly_from_json``). It imports nothing of
``rap.geometry``. Geometric validity (simple rings, holes inside, interiors disjoint) is checked by
``rap.geometry.validation``; ``rap.io.load_assembly`` / ``rap.io.parse_assembly`` read and
validate. Every problem raises ``AssemblyError`` naming the file, the part and what is wrong.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from functools import cached_property
from pathlib import Path
from typing import Iterable

from rap.errors import InputError

__all__ = [
    "Point",
    "Ring",
    "Part",
    "Assembly",
    "AssemblyError",
    "DEFAULT_FAMILY",
    "DEFAULT_UNITS",
    "check_units",
    "assembly_to_json",
    "signed_area2",
    "area_moments",
    "decimal_places",
    "InputLimits",
    "LIMITS",
    "SHIPPED_ASSEMBLIES",
    "json_error_reason",
]

Point = tuple[Fraction, Fraction]
Ring = tuple[Point, ...]


class AssemblyError(InputError):
    """A problem with an assembly file: ``file: part ID: problem`` on one line."""

    def __init__(self, source: str, part: str | None, problem: str):
        self.source, self.part, self.problem = source, part, problem
        where = f"part {part!r}: " if part is not None else ""
        super().__init__(f"{source}: {where}{problem}")


@dataclass(frozen=True)
class InputLimits:
    """The bounds of an assembly read from JSON (see the module doc for what they guarantee)."""

    max_abs_coordinate: int = 10**9
    max_decimal_places: int = 6
    max_ring_vertices: int = 10_000
    max_holes: int = 100
    max_parts: int = 1_000
    max_vertices: int = 100_000
    max_id_chars: int = 100
    max_file_bytes: int = 16 << 20

    def to_dict(self) -> dict:
        return dict(self.__dict__)


LIMITS = InputLimits()

#: the reference assemblies shipped as package data (``rap/data/assemblies/*.json``)
SHIPPED_ASSEMBLIES = Path(__file__).resolve().parent / "data" / "assemblies"


def signed_area2(ring: Iterable[Point]) -> Fraction:
    """Twice the signed area of a closed ring (positive when counter-clockwise). O(len(ring))."""
    pts = list(ring)
    s = Fraction(0)
    for i, (x0, y0) in enumerate(pts):
        x1, y1 = pts[(i + 1) % len(pts)]
        s += x0 * y1 - x1 * y0
    return s


def area_moments(rings: Iterable[Iterable[Point]]) -> tuple[Fraction, Fraction, Fraction]:
    """Exact (2A, 6A*cx, 6A*cy) of the region bounded by ``rings`` (signed: outer rings CCW, holes
    CW, so holes subtract): twice the area and six times its first moments, so the centroid is
    ``(m_x / (3 * a2), m_y / (3 * a2))``. O(total vertices)."""
    a2 = cx6 = cy6 = Fraction(0)
    for ring in rings:
        pts = list(ring)
        n = len(pts)
        for i in range(n):
            (x0, y0), (x1, y1) = pts[i], pts[(i + 1) % n]
            c = x0 * y1 - x1 * y0
            a2 += c
            cx6 += (x0 + x1) * c
            cy6 += (y0 + y1) * c
    return a2, cx6, cy6


def decimal_places(x: Fraction) -> int | None:
    """The fewest digits after the point that write ``x`` exactly as a decimal (0 for an
    integer), or None when ``x`` has no finite decimal expansion (its reduced denominator has a
    prime factor other than 2 and 5). O(log denominator)."""
    d, twos, fives = Fraction(x).denominator, 0, 0
    while d % 2 == 0:
        d, twos = d // 2, twos + 1
    while d % 5 == 0:
        d, fives = d // 5, fives + 1
    return max(twos, fives) if d == 1 else None


@dataclass(frozen=True)
class Part:
    """One rigid planar part: an outer ring (CCW) and zero or more holes (CW), exact coordinates."""

    id: str
    outer: Ring
    holes: tuple[Ring, ...] = ()

    def rings(self) -> tuple[Ring, ...]:
        return (self.outer, *self.holes)

    def float_outer(self) -> list[tuple[float, float]]:
        return list(self._float_rings[0])

    def float_holes(self) -> list[list[tuple[float, float]]]:
        return [list(h) for h in self._float_rings[1:]]

    def float_arrays(self) -> tuple:
        """The rings as float64 numpy arrays [(len, 2)], outer first; built once, read-only
        (the renderer's inner loop)."""
        return self._float_arrays

    @cached_property
    def _float_arrays(self) -> tuple:
        import numpy as np

        arrays = tuple(np.array(ring, dtype=float).reshape(-1, 2) for ring in self._float_rings)
        for a in arrays:
            a.flags.writeable = False
        return arrays

    @cached_property
    def _float_rings(self) -> tuple[tuple[tuple[float, float], ...], ...]:
        """The rings as floats, converted once (rendering and physics ask again and again)."""
        return tuple(tuple((float(x), float(y)) for x, y in ring) for ring in self.rings())

    def area(self) -> Fraction:
        return (signed_area2(self.outer) + sum(signed_area2(h) for h in self.holes)) / 2


DEFAULT_FAMILY = "custom"
DEFAULT_UNITS = "unit"  # "the drawing's units": an assembly file that names none


def check_units(units) -> str | None:
    """None when ``units`` is a valid units name (1-16 letters, e.g. "mm", "in", "unit"), else
    what is wrong, as text."""
    if not isinstance(units, str) or not units.isascii() or not units.isalpha() \
            or not 1 <= len(units) <= 16:
        return "'units' must be a word of 1 to 16 letters, e.g. \"mm\""
    return None


@dataclass(frozen=True)
class Assembly:
    """A named tuple of parts with distinct ids in their final placements.

    ``family`` says where the assembly comes from (a generator family of
    ``rap.geometry.families``, ``reference`` for the six shipped ones, ``custom`` otherwise); it
    is metadata, like ``source``, and takes no part in equality or the geometry hash; so is
    ``units``, the name of the coordinates' unit (``DEFAULT_UNITS`` when the file names none).
    """

    name: str
    parts: tuple[Part, ...]
    source: str = field(default="<memory>", compare=False)
    family: str = field(default=DEFAULT_FAMILY, compare=False)
    units: str = field(default=DEFAULT_UNITS, compare=False)

    @cached_property
    def ids(self) -> tuple[str, ...]:
        return tuple(p.id for p in self.parts)

    @cached_property
    def _index(self) -> dict[str, int]:
        return {pid: i for i, pid in enumerate(self.ids)}

    def index(self, part_id: str) -> int:
        return self._index[part_id]

    def part(self, part_id: str) -> Part:
        return self.parts[self._index[part_id]]

    def __len__(self) -> int:
        return len(self.parts)

    @cached_property
    def geometry_hash(self) -> str:
        """SHA-256 (hex, 16 chars) of the exact geometry and ids; independent of name and file."""
        h = hashlib.sha256()
        for p in self.parts:
            h.update(p.id.encode() + b"\0")
            for ring in p.rings():
                h.update(b"[" + ";".join(f"{x},{y}" for x, y in ring).encode() + b"]")
        return h.hexdigest()[:16]

    def bounds(self) -> tuple[float, float, float, float]:
        xs = [float(x) for p in self.parts for x, _ in p.outer]
        ys = [float(y) for p in self.parts for _, y in p.outer]
        return min(xs), min(ys), max(xs), max(ys)

    def subset_bounds(self, ids: Iterable[str]) -> tuple[float, float, float, float]:
        pts = [(float(x), float(y)) for i in ids for x, y in self.part(i).outer]
        xs, ys = zip(*pts)
        return min(xs), min(ys), max(xs), max(ys)


def json_error_reason(exc: Exception) -> str:
    """The first line of a JSON decoding error, short (an integer of more than 4,300 digits, which
    Python refuses to convert, is named as such)."""
    text = str(exc)
    if "integer string conversion" in text:
        return "a number with more than 4300 digits"
    return text.splitlines()[0][:200] if text else type(exc).__name__


def _num_json(v: Fraction) -> int | float:
    """A JSON number that ``rap.assembly_reader`` (decimal parsing) reads back as exactly ``v``."""
    if v.denominator == 1:
        return int(v.numerator)
    k = decimal_places(v)
    if k is None:
        raise ValueError(f"{v} has no finite decimal expansion")
    d = Decimal(v.numerator * 10 ** k // v.denominator).scaleb(-k)  # exact
    f = float(d)
    if Fraction(Decimal(repr(f))) == v:  # json writes repr(f); reading it back is exact
        return f
    raise ValueError(f"{v} cannot be written as a JSON number that reads back exactly")


def assembly_to_json(assembly: Assembly) -> dict:
    """The JSON document of an assembly (exact where coordinates have finite decimals)."""
    family = {"family": assembly.family} if assembly.family != DEFAULT_FAMILY else {}
    units = {"units": assembly.units} if assembly.units != DEFAULT_UNITS else {}
    return {
        "name": assembly.name,
        **family,
        **units,
        "parts": [
            {"id": p.id, "polygon": [[_num_json(x), _num_json(y)] for x, y in p.outer],
             **({"holes": [[[_num_json(x), _num_json(y)] for x, y in h] for h in p.holes]}
                if p.holes else {})}
            for p in assembly.parts
        ],
    }
