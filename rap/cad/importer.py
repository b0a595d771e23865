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
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from decimal import Decimal
from pathlib import Path

from rap.assembly import Assembly, AssemblyError
from rap.assembly_reader import assembly_from_json
from rap.cad.drawing import UNITS_MM, DrawingError, Problem, left_out_text
from rap.cad.loops import join_loops
from rap.cad.parts import ExactPart, group_parts
from rap.cad.rings import exact_rings
from rap.cad.snap import Grid
from rap.errors import ParameterError

__all__ = ["ImportOptions", "ImportResult", "import_drawing", "DRAWING_SUFFIXES",
           "assembly_document"]

DRAWING_SUFFIXES = (".dxf", ".svg")
PART_MODES = ("auto", "loop", "layer", "face")


@dataclass(frozen=True)
class ImportOptions:
    """``units``: the output unit (mm, cm, m, in); ``tolerance``: chordal tolerance and grid step
    in that unit (a decimal, >= 1e-6); ``parts``: ``auto`` (annotations left out, then a part per
    closed loop, or per face of the arrangement where cut lines are drawn once), ``face`` (faces
    always), ``loop`` or ``layer`` (every path read, a part per closed loop or per layer);
    ``scale``: output units per SVG user unit (default: a user unit is a CSS px where the SVG
    states no physical size); ``layers``/``skip_layers``: the layers to read or to skip."""

    units: str = "mm"
    tolerance: str = "0.01"
    parts: str = "auto"
    scale: float | None = None
    layers: tuple[str, ...] | None = None
    skip_layers: tuple[str, ...] | None = None

    def checked(self) -> Grid:
        """The tolerance's grid; ``ParameterError`` naming the option (``units``, ``parts``,
        ``scale``, ``tolerance``) that cannot be used."""
        if self.units not in UNITS_MM:
            raise ParameterError("units", self.units, f"choose one of {', '.join(UNITS_MM)}")
        if self.parts not in PART_MODES:
            raise ParameterError("parts", self.parts, f"choose one of {', '.join(PART_MODES)}")
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

    #: how the parts were made: "loops", "faces" (cut lines), or the mode asked for
    made_by: str = "loops"
    #: parts per layer, when the parts come from two or more layers
    by_layer: dict = field(default_factory=dict)

    def summary(self) -> str:
        holes = sum(len(p.holes) for p in self.assembly.parts)
        left = f"; left out: {left_out_text(Counter(self.ignored))}" if self.ignored else ""
        # parts from a few layers, one of them holding several: say which (a layer a part is
        # the naming convention of examples/, not worth a word)
        few = 1 < len(self.by_layer) <= 6 and len(self.by_layer) < len(self.assembly)
        layers = ("; parts by layer: " + ", ".join(f"{k} {n}" for k, n in self.by_layer.items())
                  + " (--layers, --skip-layers choose)" if few else "")
        return (f"{len(self.assembly)} parts ({holes} holes) as {self.made_by}, "
                f"{self.vertices} vertices, {self.gaps_closed} gaps closed, unit {self.unit} "
                f"({self.unit_note}), tolerance {self.tolerance:f} {self.unit}{left}{layers}")


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


def _overlap(a: ExactPart, b: ExactPart, grid: Grid, unit: str) -> str:
    """The overlap of two parts' outlines, for a message: its area, its depth (twice the area
    over the perimeter: a sliver's width) and the ``--tolerance`` that would absorb it."""
    import shapely

    step = grid.step_float
    pa, pb = (shapely.Polygon([(x * step, y * step) for x, y in p.outer]) for p in (a, b))
    inter = pa.intersection(pb)
    area = inter.area
    depth = 2 * area / inter.length if inter.length else 0.0
    digits = max(0, -grid.step.as_tuple().exponent)
    text = f"by {area:.{digits}f} {unit}^2, {depth:.{digits}f} {unit} deep"
    if 0 < depth < 0.05 * max(pa.area, pb.area) ** 0.5:
        nice = _nice_above(2 * depth)
        text += f" (--tolerance {nice:g} absorbs an overlap this thin)"
    return text


def _nice_above(x: float) -> float:
    """The smallest of 1, 2, 5 times a power of ten that is at least ``x``."""
    import math

    p = 10.0 ** math.floor(math.log10(x))
    for m in (1, 2, 5, 10):
        if m * p >= x:
            return float(f"{m * p:.6g}")
    return 10 * p


def _validated(doc: dict, source: str, parts: list[ExactPart], grid: Grid, unit: str
               ) -> Assembly:
    from rap.geometry.validation import validate_assembly

    by_id = {p.id: p for p in parts}

    def named(exc: AssemblyError) -> DrawingError:
        part = by_id.get(exc.part) if exc.part is not None else None
        if part is None:
            return DrawingError(source, exc.problem)
        m = _OVERLAP.match(exc.problem)
        other = by_id.get(m.group(1)) if m else None
        if other is not None:
            err = DrawingError(source, f"{part.source.describe()} and "
                                        f"{other.source.describe()}: parts {part.id!r} and "
                                        f"{other.id!r} overlap "
                                        f"{_overlap(part, other, grid, unit)}")
            err.overlap_layer = part.layer if part.layer == other.layer else None
            return err
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


#: an import slower than this is not tried again to check the tolerance a refusal names
_HINT_BUDGET_S = 2.0
_HINT = re.compile(r" \(--tolerance (\S+) absorbs an overlap this thin\)")


def import_drawing(path: str | Path, options: ImportOptions = ImportOptions()) -> ImportResult:
    """Import a DXF or SVG drawing as a validated exact assembly (see the module doc).

    A refusal that names a ``--tolerance`` has been checked: the import was tried again with it
    and succeeded; where it did not, the refusal says that no tolerance that small merges the
    overlap (so no message names a flag that would not work)."""
    started = time.perf_counter()
    try:
        return _import(path, options)
    except DrawingError as exc:
        m = _HINT.search(exc.problem)
        if m is None:
            raise
        if time.perf_counter() - started > _HINT_BUDGET_S:  # too large to try again and again
            raise DrawingError(exc.source, _HINT.sub(" (a coarser --tolerance may absorb it; "
                                                     "not tried on a drawing this large)",
                                                     exc.problem)) from None
        first = float(m.group(1))
        tolerances = (first, _nice_above(2.01 * first), _nice_above(4.01 * first))
        layer = getattr(exc, "overlap_layer", None)
        tries = [(t, None) for t in tolerances]
        if layer is not None and not options.layers:
            tries += [(t, layer) for t in tolerances]
        for tolerance, only in tries:
            flags = (f"--layers {only} " if only else "") + f"--tolerance {tolerance:g}"
            try:
                got = _import(path, replace(options, tolerance=f"{tolerance:g}",
                                            layers=(only,) if only else options.layers))
            except (DrawingError, ParameterError):
                continue
            if got.made_by.startswith("loops") and len(got.assembly) == getattr(exc, "parts",
                                                                                  -1):
                raise DrawingError(exc.source, _HINT.sub(f" ({flags} absorbs the overlaps)",
                                                         exc.problem)) from None
        raise DrawingError(exc.source, _HINT.sub(
            f": the pieces overlap as drawn (no --tolerance up to {tolerances[-1]:g} "
            f"merges them into as many parts)", exc.problem)) from None


def _import(path: str | Path, options: ImportOptions) -> ImportResult:
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
        drawing = _read(path, suffix, options, tol)
        from rap.cad.layers import choose_layers

        paths = choose_layers(drawing, options.layers, options.skip_layers)
        ignored = Counter(drawing.ignored)
        if not paths:
            found = left_out_text(ignored) or "nothing"
            raise Problem(f"no closed loop found: no lines, arcs, circles, ellipses, splines, "
                          f"polylines or paths (found {found})")
        parts, gaps, made_by, kept = _parts(paths, grid, options, ignored, drawing.page,
                                             drawing.locked)
    except Problem as exc:
        raise DrawingError(source, str(exc)) from None
    doc = assembly_document(path.stem or "drawing", parts, grid, options.units)
    try:
        assembly = _validated(doc, source, parts, grid, options.units)
    except DrawingError as exc:
        exc.parts = len(parts)  # what a tolerance that absorbs an overlap must keep
        if made_by != "loops" or options.parts != "auto":
            raise
        try:  # pieces placed by hand, overlapping by a hair: give each overlap to one piece
            parts = _overlay(kept, grid, options)
            assembly = _validated(assembly_document(path.stem or "drawing", parts, grid,
                                                    options.units), source, parts, grid,
                                  options.units)
        except (Problem, DrawingError):
            raise exc from None
        made_by = OVERLAID
    by_layer = Counter(p.layer for p in parts if p.layer is not None)
    return ImportResult(assembly, gaps, options.units, grid.step, drawing.unit_note,
                        dict(ignored), made_by, dict(by_layer))


def _read(path: Path, suffix: str, options: ImportOptions, tol: float):
    if suffix == ".dxf":
        from rap.cad.dxf import read_dxf

        return read_dxf(path, options.units, tol)
    from rap.cad.svg import read_svg

    return read_svg(path, options.units, tol, options.scale)


def _loop_parts(paths, grid: Grid, options: ImportOptions, by: str):
    loops = join_loops(paths, grid.step_float, options.units)
    if not loops:
        raise Problem("no closed loop found (every path is degenerate)")
    rings, gaps = exact_rings(loops, grid, options.units)
    return group_parts(rings, by), gaps


_GAP = re.compile(r"the gap to the nearest free end, .* is (\S+) \S+$")


def _open_loop_gap(paths, grid: Grid, options: ImportOptions) -> None:
    """Where every path was left out as open: if the loose paths are loops with a gap, raise
    the loop builder's message naming it and the ``--tolerance`` that closes it."""
    try:
        join_loops([p for p in paths if p.construction is None], grid.step_float, options.units)
    except Problem as exc:
        m = _GAP.search(str(exc))
        if m:
            raise Problem(f"{exc}: --tolerance {_nice_above(1.01 * float(m.group(1))):g} "
                          f"closes it") from None


#: how parts were made when hand-placed loops overlapped by at most the tolerance
OVERLAID = "loops, thin overlaps resolved"


def _overlay(kept, grid: Grid, options: ImportOptions):
    from rap.cad.arrangement.overlay import overlay_parts

    return overlay_parts(join_loops(kept, grid.step_float, options.units), grid, options.units)


def _parts(paths, grid: Grid, options: ImportOptions, ignored: Counter, page=None,
           locked=frozenset()):
    """(parts, gaps closed, how they were made, the paths read) for the chosen mode (see
    ``ImportOptions``)."""
    if options.parts in ("loop", "layer"):
        parts, gaps = _loop_parts(paths, grid, options, options.parts)
        return parts, gaps, f"{options.parts}s", paths
    from rap.cad.arrangement.annotations import sort_out
    from rap.cad.arrangement.faces import face_parts

    sorting = sort_out(paths, grid.step_float, page, locked)
    ignored.update(sorting.left_out)
    if not sorting.kept:
        _open_loop_gap(paths, grid, options)
        raise Problem(f"no part found: every path is an annotation (left out: "
                      f"{left_out_text(ignored)}); choose layers with --layers, or "
                      f"--parts loop to read every path")
    kept = sorting.kept
    if options.parts == "face" or sorting.networks:
        parts, gaps = face_parts(kept, grid)
        return parts, gaps, "faces", kept
    try:
        parts, gaps = _loop_parts(kept, grid, options, "loop")
        return parts, gaps, "loops", kept
    except Problem as exc:  # a crossing made by rounding: snap rounding keeps rings simple
        if "self-intersection" not in str(exc):
            raise
        parts, gaps = face_parts(kept, grid)
        if len(parts) == sorting.loop_parts:
            return parts, gaps, "faces", kept
        try:  # hand-placed pieces whose nodes merged across a hair's overlap
            return _overlay(kept, grid, options), 0, OVERLAID, kept
        except Problem:  # a loop that crosses itself, not a rounding
            if len(kept) == 1:  # one stroke drawing every cut
                raise Problem(f"{exc}; as a cut path its crossings bound {len(parts)} faces: "
                              f"--parts face reads them as parts") from None
            raise
