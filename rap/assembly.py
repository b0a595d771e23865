"""Assemblies: planar polygonal parts in their final placements, read exactly.

An assembly file is JSON::

    {"name": "optional", "parts": [{"id": "a", "polygon": [[x, y], ...],
                                    "holes": [[[x, y], ...], ...]}]}

Every JSON number is parsed as a decimal (never through a binary float) and stored as a
``fractions.Fraction``, so shared edges and touching contacts stay exact. Rings are
normalised: outer boundaries counter-clockwise, holes clockwise.

**Input bounds** (``LIMITS``, an ``InputLimits``), checked while reading, before any geometry:
every coordinate is a decimal with ``|x| <= 10^9`` and at most 6 digits after the point (so
``x * 10^6`` is an integer of at most 10^15 < 2^53), a ring has at most 10,000 vertices, a part at
most 100 holes, an assembly at most 1,000 parts and 100,000 vertices in all, an id at most 100
characters, a file at most 16 MiB. What they guarantee downstream: the exact layer scales by at
most 10^6 (``rap.geometry.exact.to_integers``) and its predicates multiply integers of at most 51
bits (products under 2^104: constant-time machine-word-sized big ints, never million-digit ones);
every coordinate and every difference of two is a float without overflow, distinct points stay
distinct as floats (the physics and the renderer convert them); a number's text is looked at
before it is converted, so ``1e-1000000`` costs what its 10 characters cost. Reading is linear in
the file's size.

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
    "InputLimits",
    "LIMITS",
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


def _shown(value: Any, width: int = 40) -> str:
    """``repr(value)`` cut to ``width`` characters (an error line never echoes a whole input)."""
    text = str(value) if isinstance(value, (int, Decimal)) and not isinstance(value, bool) \
        else repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."


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
    """A coordinate within ``LIMITS``, as a Fraction; the bounds are checked on the number's digits
    and exponent before anything is computed from it."""
    if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
        raise AssemblyError(source, part, f"coordinate {_shown(value)} is not a number")
    bound = LIMITS.max_abs_coordinate
    if isinstance(value, int):
        if not -bound <= value <= bound:
            raise AssemblyError(source, part, f"coordinate {_shown(value)} is out of range "
                                              f"(|x| <= 10^9)")
        return Fraction(value)
    if not value.is_finite():
        raise AssemblyError(source, part, f"coordinate {value} is not finite")
    sign, digits, exponent = value.as_tuple()
    if not any(digits):
        return Fraction(0)
    if exponent + len(digits) - 1 > 9 or value.copy_abs() > bound:  # the leading digit's place first
        raise AssemblyError(source, part, f"coordinate {_shown(value)} is out of range "
                                          f"(|x| <= 10^9)")
    significant = len(digits)
    while digits[significant - 1] == 0:  # trailing zeros: 2.500 is 2.5
        significant -= 1
        exponent += 1
    if exponent < -LIMITS.max_decimal_places:
        raise AssemblyError(source, part, f"coordinate {_shown(value)} has more than "
                                          f"{LIMITS.max_decimal_places} digits after the point "
                                          f"(the grid is 10^-{LIMITS.max_decimal_places}: scale "
                                          f"the drawing or round it)")
    # at most 16 significant digits are left: the Fraction is built from them, never from the
    # text's full length (Fraction(Decimal) would compute 10^len for "1.000...0")
    mantissa = int("".join(map(str, digits[:significant])))
    mantissa = -mantissa if sign else mantissa
    return Fraction(mantissa * 10 ** exponent) if exponent >= 0 else Fraction(mantissa,
                                                                              10 ** -exponent)


def _reject_constant(name: str) -> Any:
    raise ValueError(f"non-finite number {name} is not allowed")


def _ring(raw: Any, source: str, part: str, what: str, limits: InputLimits = LIMITS) -> Ring:
    if not isinstance(raw, list):
        raise AssemblyError(source, part, f"{what} must be a list of [x, y] points")
    if len(raw) > limits.max_ring_vertices:
        raise AssemblyError(source, part, f"{what} has {len(raw)} vertices; at most "
                                          f"{limits.max_ring_vertices} are read")
    pts: list[Point] = []
    for p in raw:
        if not (isinstance(p, list) and len(p) == 2):
            raise AssemblyError(source, part, f"{what} has a point {_shown(p)} that is not [x, y]")
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


def assembly_from_json(data: Any, source: str = "<memory>", default_name: str = "assembly",
                       limits: InputLimits = LIMITS) -> Assembly:
    """Build an ``Assembly`` from decoded JSON (numbers as ``int``/``Decimal``), exactly.

    Raises ``AssemblyError`` for any structural problem (types, ids, ring sizes, repeated
    vertices, zero area) or anything past ``limits`` (a caller such as the planning service may
    pass smaller sizes; coordinates are always bounded by ``LIMITS``). Geometric validity is not
    checked here: ``rap.io.parse_assembly`` adds ``rap.geometry.validation``. O(total vertices).
    """
    if not isinstance(data, dict):
        raise AssemblyError(source, None, "top level must be a JSON object with a 'parts' list")
    if "parts" not in data:
        raise AssemblyError(source, None, "missing key 'parts'")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name or len(name) > 2 * LIMITS.max_id_chars:
        raise AssemblyError(source, None, f"'name' must be a non-empty string of at most "
                                          f"{2 * LIMITS.max_id_chars} characters")
    family = data.get("family", DEFAULT_FAMILY)
    if not isinstance(family, str) or not family or not family.replace("-", "").replace("_", "").isalnum():
        raise AssemblyError(source, None, "'family' must be a non-empty word (letters, digits, - or _)")
    raw_parts = data["parts"]
    if not isinstance(raw_parts, list):
        raise AssemblyError(source, None, "'parts' must be a list")
    if not raw_parts:
        raise AssemblyError(source, None, "'parts' is empty")
    if len(raw_parts) > limits.max_parts:
        raise AssemblyError(source, None, f"{len(raw_parts)} parts; at most {limits.max_parts} "
                                          f"are read")
    vertices = 0
    parts: list[Part] = []
    seen: set[str] = set()
    for k, rp in enumerate(raw_parts):
        label = f"#{k}"
        if not isinstance(rp, dict):
            raise AssemblyError(source, label, "each part must be an object with 'id' and 'polygon'")
        if "id" not in rp:
            raise AssemblyError(source, label, "missing key 'id'")
        pid = rp["id"]
        if not isinstance(pid, str) or not pid or "," in pid or len(pid) > LIMITS.max_id_chars:
            raise AssemblyError(source, label, f"'id' must be a non-empty string without commas, "
                                               f"of at most {LIMITS.max_id_chars} characters")
        if pid in seen:
            raise AssemblyError(source, pid, "duplicate id")
        seen.add(pid)
        if "polygon" not in rp:
            raise AssemblyError(source, pid, "missing key 'polygon'")
        outer = _oriented(_ring(rp["polygon"], source, pid, "polygon", limits), ccw=True)
        raw_holes = rp.get("holes", [])
        if not isinstance(raw_holes, list):
            raise AssemblyError(source, pid, "'holes' must be a list of rings")
        if len(raw_holes) > limits.max_holes:
            raise AssemblyError(source, pid, f"{len(raw_holes)} holes; at most {limits.max_holes} "
                                             f"are read")
        holes = tuple(_oriented(_ring(h, source, pid, f"hole {j}", limits), ccw=False)
                      for j, h in enumerate(raw_holes))
        vertices += len(outer) + sum(len(h) for h in holes)
        if vertices > limits.max_vertices:
            raise AssemblyError(source, pid, f"the assembly has more than {limits.max_vertices} "
                                             f"vertices in all; no more are read")
        parts.append(Part(pid, outer, holes))
    return Assembly(name, tuple(parts), source, family)


_BINARY_KINDS = ((b"\x89PNG", "a PNG image"), (b"%PDF", "a PDF document"), (b"\xff\xd8\xff", "a JPEG image"),
                 (b"PK\x03\x04", "a ZIP archive"), (b"GIF8", "a GIF image"), (b"PAR1", "a Parquet file"))


def read_assembly_json(path: str | Path) -> Assembly:
    """Read an assembly JSON file exactly (structural checks only; ``rap.io.load_assembly``
    validates the geometry too). Raises ``AssemblyError`` (one line) for a missing, unreadable,
    binary, oversized (``LIMITS.max_file_bytes``), too deeply nested or invalid file. Cost: linear
    in the file's size."""
    path = Path(path)
    source = str(path)
    try:
        with path.open("rb") as fh:
            raw = fh.read(LIMITS.max_file_bytes + 1)
    except FileNotFoundError:
        raise AssemblyError(source, None, "no such file") from None
    except IsADirectoryError:
        raise AssemblyError(source, None, "is a directory, not an assembly file") from None
    except OSError as exc:
        raise AssemblyError(source, None, f"cannot read: {exc.strerror or exc}") from None
    if len(raw) > LIMITS.max_file_bytes:
        raise AssemblyError(source, None, f"file over {LIMITS.max_file_bytes >> 20} MiB; an "
                                          f"assembly file is read up to that size")
    for magic, kind in _BINARY_KINDS:
        if raw.startswith(magic):
            raise AssemblyError(source, None, f"is {kind}, not an assembly (JSON, DXF or SVG)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise AssemblyError(source, None, f"not UTF-8 text (byte {exc.start}), so not an assembly "
                                          f"(JSON, DXF or SVG)") from None
    try:
        data = json.loads(text, parse_float=Decimal, parse_int=int, parse_constant=_reject_constant)
    except RecursionError:
        raise AssemblyError(source, None, "JSON nested too deeply (an assembly file needs 5 "
                                          "levels)") from None
    except (json.JSONDecodeError, ValueError, InvalidOperation) as exc:
        raise AssemblyError(source, None, f"not valid JSON: {json_error_reason(exc)}") from None
    return assembly_from_json(data, source, default_name=path.stem)


def json_error_reason(exc: Exception) -> str:
    """The first line of a JSON decoding error, short (an integer of more than 4,300 digits, which
    Python refuses to convert, is named as such)."""
    text = str(exc)
    if "integer string conversion" in text:
        return "a number with more than 4300 digits"
    return text.splitlines()[0][:200] if text else type(exc).__name__


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
