"""Reading assembly JSON exactly, within the input bounds: untrusted text to an ``Assembly``.

Every JSON number is parsed as a decimal (never through a binary float) and stored as a
``fractions.Fraction``, so shared edges and touching contacts stay exact. Rings are normalised:
outer boundaries counter-clockwise, holes clockwise. The bounds (``rap.assembly.LIMITS``, an
``rap.assembly.InputLimits``: what they are and what they guarantee downstream is said there) are
checked while reading, before any geometry: a number's text is looked at before it is converted,
so ``1e-1000000`` costs what its 10 characters cost.

* ``read_assembly_json(path)``: a file (missing, unreadable, binary, oversized, too deeply nested
  or invalid JSON each one line), then ``assembly_from_json``. Linear in the file's size.
* ``assembly_from_json(data)``: decoded JSON (numbers as ``int``/``Decimal``) to an ``Assembly``,
  with the structural checks (types, ids, ring sizes, repeated vertices, zero area).
  O(total vertices).

Structural checks only: geometric validity (simple rings, holes inside, interiors disjoint) is
``rap.geometry.validation``'s; ``rap.io.load_assembly`` / ``rap.io.parse_assembly`` do both.
Every problem raises ``AssemblyError`` naming the file, the part and what is wrong. Writing is
``rap.assembly.assembly_to_json``.
"""

from __future__ import annotations

import json
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from pathlib import Path
from typing import Any

from rap.assembly import (DEFAULT_FAMILY, DEFAULT_UNITS, LIMITS, Assembly, AssemblyError,
                          InputLimits, Part, Point, Ring, check_units, json_error_reason,
                          signed_area2)

__all__ = ["assembly_from_json", "read_assembly_json"]


def _shown(value: Any, width: int = 40) -> str:
    """``repr(value)`` cut to ``width`` characters (an error line never echoes a whole input)."""
    text = str(value) if isinstance(value, (int, Decimal)) and not isinstance(value, bool) \
        else repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."


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
    units = data.get("units", DEFAULT_UNITS)
    if check_units(units) is not None:
        raise AssemblyError(source, None, check_units(units))
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
    return Assembly(name, tuple(parts), source, family, units)


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
