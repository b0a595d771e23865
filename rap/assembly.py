"""Assemblies: planar polygonal parts in their final placements, read exactly.

An assembly file is JSON::

    {"name": "optional", "parts": [{"id": "a", "polygon": [[x, y], ...],
                                    "holes": [[[x, y], ...], ...]}]}

Every JSON number is parsed as a decimal (never through a binary float) and stored as a
``fractions.Fraction``, so shared edges and touching contacts stay exact. Rings are
normalised: outer boundaries counter-clockwise, holes clockwise.

This module holds the data and the exact structural parsing only; it imports nothing of
``rap.geometry``. Geometric validity (simple rings, holes inside, interiors disjoint) is checked by
``rap.geometry.validation``; ``rap.io.load_assembly`` / ``rap.io.parse_assembly`` do both. Every
problem raises ``AssemblyError`` naming the file, the part and what is wrong.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable

from rap.errors import InputError

__all__ = [
    "Point",
    "Ring",
    "Part",
    "Assembly",
    "AssemblyError",
    "DEFAULT_FAMILY",
    "assembly_from_json",
    "read_assembly_json",
    "assembly_to_json",
    "signed_area2",
]

Point = tuple[Fraction, Fraction]
Ring = tuple[Point, ...]


class AssemblyError(InputError):
    """A problem with an assembly file: ``file: part ID: problem`` on one line."""

    def __init__(self, source: str, part: str | None, problem: str):
        self.source, self.part, self.problem = source, part, problem
        where = f"part {part!r}: " if part is not None else ""
        super().__init__(f"{source}: {where}{problem}")


def signed_area2(ring: Iterable[Point]) -> Fraction:
    """Twice the signed area of a closed ring (positive when counter-clockwise). O(len(ring))."""
    pts = list(ring)
    s = Fraction(0)
    for i, (x0, y0) in enumerate(pts):
        x1, y1 = pts[(i + 1) % len(pts)]
        s += x0 * y1 - x1 * y0
    return s


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


@dataclass(frozen=True)
class Assembly:
    """A named tuple of parts with distinct ids in their final placements.

    ``family`` says where the assembly comes from (a generator family of
    ``rap.geometry.families``, ``reference`` for the six shipped ones, ``custom`` otherwise); it
    is metadata, like ``source``, and takes no part in equality or the geometry hash.
    """

    name: str
    parts: tuple[Part, ...]
    source: str = field(default="<memory>", compare=False)
    family: str = field(default=DEFAULT_FAMILY, compare=False)

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


def _number(value: Any, source: str, part: str | None) -> Fraction:
    if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
        raise AssemblyError(source, part, f"coordinate {value!r} is not a number")
    if isinstance(value, Decimal) and not value.is_finite():
        raise AssemblyError(source, part, f"coordinate {value} is not finite")
    return Fraction(value)


def _reject_constant(name: str) -> Any:
    raise ValueError(f"non-finite number {name} is not allowed")


def _ring(raw: Any, source: str, part: str, what: str) -> Ring:
    if not isinstance(raw, list):
        raise AssemblyError(source, part, f"{what} must be a list of [x, y] points")
    pts: list[Point] = []
    for p in raw:
        if not (isinstance(p, list) and len(p) == 2):
            raise AssemblyError(source, part, f"{what} has a point {p!r} that is not [x, y]")
        pts.append((_number(p[0], source, part), _number(p[1], source, part)))
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()  # tolerate an explicitly closed ring
    if len(pts) < 3:
        raise AssemblyError(source, part, f"{what} has {len(pts)} vertices; at least 3 are needed")
    if len(set(pts)) != len(pts):
        raise AssemblyError(source, part, f"{what} repeats a vertex")
    area2 = signed_area2(pts)
    if area2 == 0:
        raise AssemblyError(source, part, f"{what} has zero area (collinear vertices)")
    return tuple(pts)


def _oriented(ring: Ring, ccw: bool) -> Ring:
    return ring if (signed_area2(ring) > 0) == ccw else tuple(reversed(ring))


def assembly_from_json(data: Any, source: str = "<memory>", default_name: str = "assembly") -> Assembly:
    """Build an ``Assembly`` from decoded JSON (numbers as ``int``/``Decimal``), exactly.

    Raises ``AssemblyError`` for any structural problem (types, ids, ring sizes, repeated
    vertices, zero area). Geometric validity is not checked here: ``rap.io.parse_assembly`` adds
    ``rap.geometry.validation``. O(total vertices).
    """
    if not isinstance(data, dict):
        raise AssemblyError(source, None, "top level must be a JSON object with a 'parts' list")
    if "parts" not in data:
        raise AssemblyError(source, None, "missing key 'parts'")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise AssemblyError(source, None, "'name' must be a non-empty string")
    family = data.get("family", DEFAULT_FAMILY)
    if not isinstance(family, str) or not family or not family.replace("-", "").replace("_", "").isalnum():
        raise AssemblyError(source, None, "'family' must be a non-empty word (letters, digits, - or _)")
    raw_parts = data["parts"]
    if not isinstance(raw_parts, list):
        raise AssemblyError(source, None, "'parts' must be a list")
    if not raw_parts:
        raise AssemblyError(source, None, "'parts' is empty")
    parts: list[Part] = []
    seen: set[str] = set()
    for k, rp in enumerate(raw_parts):
        label = f"#{k}"
        if not isinstance(rp, dict):
            raise AssemblyError(source, label, "each part must be an object with 'id' and 'polygon'")
        if "id" not in rp:
            raise AssemblyError(source, label, "missing key 'id'")
        pid = rp["id"]
        if not isinstance(pid, str) or not pid or "," in pid:
            raise AssemblyError(source, label, "'id' must be a non-empty string without commas")
        if pid in seen:
            raise AssemblyError(source, pid, "duplicate id")
        seen.add(pid)
        if "polygon" not in rp:
            raise AssemblyError(source, pid, "missing key 'polygon'")
        outer = _oriented(_ring(rp["polygon"], source, pid, "polygon"), ccw=True)
        raw_holes = rp.get("holes", [])
        if not isinstance(raw_holes, list):
            raise AssemblyError(source, pid, "'holes' must be a list of rings")
        holes = tuple(_oriented(_ring(h, source, pid, f"hole {j}"), ccw=False)
                      for j, h in enumerate(raw_holes))
        parts.append(Part(pid, outer, holes))
    return Assembly(name, tuple(parts), source, family)


def read_assembly_json(path: str | Path) -> Assembly:
    """Read an assembly JSON file exactly (structural checks only; ``rap.io.load_assembly``
    validates the geometry too). Raises ``AssemblyError`` (one line)."""
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise AssemblyError(source, None, "no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise AssemblyError(source, None, f"cannot read: {exc}") from None
    try:
        data = json.loads(text, parse_float=Decimal, parse_int=int, parse_constant=_reject_constant)
    except (json.JSONDecodeError, ValueError, InvalidOperation) as exc:
        raise AssemblyError(source, None, f"not valid JSON: {exc}") from None
    return assembly_from_json(data, source, default_name=path.stem)


def _num_json(v: Fraction) -> int | float:
    """A JSON number that ``read_assembly_json`` (decimal parsing) reads back as exactly ``v``."""
    if v.denominator == 1:
        return int(v.numerator)
    den, twos, fives = v.denominator, 0, 0
    while den % 2 == 0:
        den, twos = den // 2, twos + 1
    while den % 5 == 0:
        den, fives = den // 5, fives + 1
    if den != 1:
        raise ValueError(f"{v} has no finite decimal expansion")
    k = max(twos, fives)
    d = Decimal(v.numerator * 10 ** k // v.denominator).scaleb(-k)  # exact
    f = float(d)
    if Fraction(Decimal(repr(f))) == v:  # json writes repr(f); reading it back is exact
        return f
    raise ValueError(f"{v} cannot be written as a JSON number that reads back exactly")


def assembly_to_json(assembly: Assembly) -> dict:
    """The JSON document of an assembly (exact where coordinates have finite decimals)."""
    family = {"family": assembly.family} if assembly.family != DEFAULT_FAMILY else {}
    return {
        "name": assembly.name,
        **family,
        "parts": [
            {"id": p.id, "polygon": [[_num_json(x), _num_json(y)] for x, y in p.outer],
             **({"holes": [[[_num_json(x), _num_json(y)] for x, y in h] for h in p.holes]}
                if p.holes else {})}
            for p in assembly.parts
        ],
    }
