"""A drawing (DXF or SVG) to a validated exact assembly: the pipeline behind ``rap-farm import``.

``import_drawing(path, ImportOptions(...)) -> ImportResult``:

1. read the drawing into float paths in the output unit (``rap.cad.dxf``, ``rap.cad.svg``),
   curves flattened to the tolerance;
2. join open paths into closed loops (``rap.cad.loops.join_loops``);
3. snap the loops onto the grid of the tolerance, shared boundaries given the same vertices
   (``rap.cad.rings.exact_rings``; ``rap.cad.edges``: how touching stays touching);
4. nest the rings into parts with holes (``rap.cad.parts.group_parts``);
5. build the assembly's JSON document (coordinates as exact decimals, multiples of the tolerance)
   and validate it as ``rap.io.parse_assembly`` does: ``rap.assembly_reader.assembly_from_json``
   (``LIMITS``) then ``rap.geometry.validation.validate_assembly`` (simple rings, holes strictly
   inside, interiors of parts disjoint). ``rap.io`` sits above this package and dispatches
   drawings to it, so the two steps are called here directly.

Every problem is one ``DrawingError`` line naming the file, the entity (DXF handle and layer, or
SVG element id) and what is wrong: an open loop with its gap, a self-intersection, parts that
overlap, no closed loop, an SVG without physical units. Options are checked before the file is
read. ``ImportResult.summary()`` is the line ``rap-farm import`` prints.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

from rap.assembly import Assembly, AssemblyError
from rap.assembly_reader import assembly_from_json
from rap.cad.drawing import UNITS_MM, DrawingError, Problem
from rap.cad.loops import join_loops
from rap.cad.parts import ExactPart, group_parts
from rap.cad.rings import exact_rings
from rap.cad.snap import Grid
from rap.errors import ParameterError

__all__ = ["ImportOptions", "ImportResult", "import_drawing", "DRAWING_SUFFIXES",
           "assembly_document"]

DRAWING_SUFFIXES = (".dxf", ".svg")
PART_MODES = ("loop", "layer")


@dataclass(frozen=True)
class ImportOptions:
    """``units``: the output unit (mm, cm, m, in); ``tolerance``: chordal tolerance and grid step
    in that unit (a decimal, >= 1e-6); ``parts``: a part per closed ``loop`` or per ``layer``;
    ``scale``: output units per SVG user unit (needed for an SVG without physical units)."""

    units: str = "mm"
    tolerance: str = "0.01"
    parts: str = "loop"
    scale: float | None = None

    def checked(self) -> Grid:
        """The tolerance's grid; ``ParameterError`` naming the option (``units``, ``parts``,
        ``scale``, ``tolerance``) that cannot be used."""
        if self.units not in UNITS_MM:
            raise ParameterError("units", self.units, f"choose one of {', '.join(UNITS_MM)}")
        if self.parts not in PART_MODES:
            raise ParameterError("parts", self.parts, "choose loop or layer")
        if self.scale is not None and not self.scale > 0:
            raise ParameterError("scale", self.scale, "must be a positive number")
        return Grid.parse(self.tolerance)


@dataclass(frozen=True)
class ImportResult:
    """The validated assembly and what the import did."""

    assembly: Assembly
    gaps_closed: int
    unit: str
    tolerance: Decimal
    unit_note: str
    ignored: dict = field(default_factory=dict)

    @property
    def vertices(self) -> int:
        return sum(len(p.outer) + sum(len(h) for h in p.holes) for p in self.assembly.parts)

    def summary(self) -> str:
        holes = sum(len(p.holes) for p in self.assembly.parts)
        left = ("; left out: " + ", ".join(f"{n} {k}" for k, n in sorted(self.ignored.items()))
                if self.ignored else "")
        return (f"{len(self.assembly)} parts ({holes} holes), {self.vertices} vertices, "
                f"{self.gaps_closed} gaps closed, unit {self.unit} ({self.unit_note}), "
                f"tolerance {self.tolerance:f} {self.unit}{left}")


def assembly_document(name: str, parts: list[ExactPart], grid: Grid, units: str | None = None
                      ) -> dict:
    """The assembly JSON document (numbers as exact ``int``/``Decimal``) of exact parts;
    ``units``: the coordinates' unit, stated in the document (``"units"``) when given."""
    def ring(r):
        return [[grid.value(x), grid.value(y)] for x, y in r]

    return {"name": name, **({"units": units} if units else {}), "parts": [
        {"id": p.id, "polygon": ring(p.outer), **({"holes": [ring(h) for h in p.holes]}
                                                  if p.holes else {})}
        for p in parts]}


_OVERLAP = re.compile(r"^overlaps part '(.*)'$", re.S)


def _validated(doc: dict, source: str, parts: list[ExactPart]) -> Assembly:
    from rap.geometry.validation import validate_assembly

    by_id = {p.id: p for p in parts}

    def named(exc: AssemblyError) -> DrawingError:
        part = by_id.get(exc.part) if exc.part is not None else None
        if part is None:
            return DrawingError(source, exc.problem)
        m = _OVERLAP.match(exc.problem)
        other = by_id.get(m.group(1)) if m else None
        if other is not None:
            return DrawingError(source, f"{part.source.describe()} and "
                                        f"{other.source.describe()}: parts {part.id!r} and "
                                        f"{other.id!r} overlap")
        def hole(m: re.Match) -> str:
            k = int(m.group(1))
            return f"the hole {part.hole_sources[k].describe()}" if k < len(part.hole_sources) \
                else m.group(0)

        problem = re.sub(r"\bhole (\d+)", hole, exc.problem)
        problem = re.sub(r"\bholes (\d+) and (\d+)", lambda m: (
            f"the holes {part.hole_sources[int(m.group(1))].describe()} and "
            f"{part.hole_sources[int(m.group(2))].describe()}"), problem)
        return DrawingError(source, f"{part.source.describe()} (part {part.id!r}): {problem}")

    try:
        assembly = assembly_from_json(doc, source, default_name=doc["name"])
        validate_assembly(assembly)
    except AssemblyError as exc:
        raise named(exc) from None
    return assembly


def import_drawing(path: str | Path, options: ImportOptions = ImportOptions()) -> ImportResult:
    """Import a DXF or SVG drawing as a validated exact assembly (see the module doc)."""
    path = Path(path)
    source = str(path)
    suffix = path.suffix.lower()
    if suffix not in DRAWING_SUFFIXES:
        raise DrawingError(source, f"not a drawing: the suffix must be one of "
                                   f"{', '.join(DRAWING_SUFFIXES)}")
    grid = options.checked()
    if not path.is_file():
        raise DrawingError(source, "no such file" if not path.exists() else "not a file")
    tol = grid.step_float
    try:
        if suffix == ".dxf":
            from rap.cad.dxf import read_dxf

            drawing = read_dxf(path, options.units, tol)
        else:
            from rap.cad.svg import read_svg

            drawing = read_svg(path, options.units, tol, options.scale)
        if not drawing.paths:
            found = ", ".join(f"{n} {k}" for k, n in sorted(drawing.ignored.items())) or "nothing"
            raise Problem(f"no closed loop found: no lines, arcs, circles, ellipses, splines, "
                          f"polylines or paths (found {found})")
        loops = join_loops(drawing.paths, tol, options.units)
        if not loops:
            raise Problem("no closed loop found (every path is degenerate)")
        rings, gaps = exact_rings(loops, grid, options.units)
        parts = group_parts(rings, options.parts)
    except Problem as exc:
        raise DrawingError(source, str(exc)) from None
    doc = assembly_document(path.stem or "drawing", parts, grid, options.units)
    assembly = _validated(doc, source, parts)
    return ImportResult(assembly, gaps, options.units, grid.step, drawing.unit_note,
                        dict(drawing.ignored))
