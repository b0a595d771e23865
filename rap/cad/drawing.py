"""What the readers of drawings hand to the loop builder: paths of float polylines in output units.

A reader (``rap.cad.dxf``, ``rap.cad.svg``) turns each entity or subpath into a ``DrawnPath``: its
pieces are consecutive primitives (a line, an arc, a Bezier, a spline...), each already flattened
to a float polyline whose chords stay within the chordal tolerance of the curve, in the output unit
(millimetres by default), y up. Each piece keeps its first and last points exactly as the entity
defines them, so that the ends of pieces can be joined (``rap.cad.loops``), merged and split
(``rap.cad.edges``); the interior points are the curve's flattening. ``Source`` names the entity
in error messages (a DXF handle and layer, an SVG element id) and gives the parts their ids.

``Problem`` is raised by the builders with a message that names the entities but not the file;
``rap.cad.importer`` turns it into ``DrawingError``, an ``AssemblyError`` (exit status 2) of one
line: ``FILE: ENTITY: problem``. No third-party imports.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from rap.assembly import AssemblyError

__all__ = ["Point", "Source", "DrawnPath", "Drawing", "Problem", "DrawingError", "UNITS_MM",
           "distance", "fmt_length", "fmt_point", "left_out_text"]

Point = tuple[float, float]

#: output units and their size in millimetres (exact decimals)
UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


class DrawingError(AssemblyError):
    """A drawing that cannot be imported: ``FILE: ENTITY: problem`` on one line (exit status 2)."""

    def __init__(self, source: str, problem: str):
        super().__init__(source, None, problem)


class Problem(Exception):
    """A problem found by a builder; the importer adds the file's name (``DrawingError``)."""


@dataclass(frozen=True)
class Source:
    """Where a path comes from.

    ``dialect`` is ``"dxf"`` or ``"svg"``; ``kind`` the DXF entity type or SVG tag; ``ident`` the
    DXF handle or the SVG element id (None when the element has none); ``layer`` the DXF layer or
    the SVG top-level group (None outside groups); ``order`` the position in the file (parts and
    loops are sorted by it, so an import is deterministic); ``subpath`` the SVG subpath index.
    """

    dialect: str
    kind: str
    ident: str | None
    layer: str | None
    order: int
    subpath: int = 0

    def describe(self) -> str:
        if self.dialect == "dxf":
            return f"{self.kind} {self.ident} on layer {self.layer!r}"
        who = f"<{self.kind} id={self.ident!r}>" if self.ident else \
            f"<{self.kind}> #{self.order} (no id)"
        return who + (f" subpath {self.subpath + 1}" if self.subpath else "")

    def name(self) -> str:
        """The base of a part id: the DXF layer, the SVG element id (or tag and number)."""
        if self.dialect == "dxf":
            return self.layer or "0"
        return self.ident or f"{self.kind}{self.order}"

    def tag(self) -> str:
        """What tells two loops of the same ``name`` apart: the DXF handle, the SVG subpath."""
        return str(self.ident) if self.dialect == "dxf" else str(self.subpath + 1)


@dataclass
class DrawnPath:
    """Consecutive pieces (float polylines of >= 2 points, the end of one the start of the next),
    closed when the last piece ends where the first begins."""

    pieces: list[list[Point]]
    source: Source
    closed: bool
    #: why the path is construction rather than a part's outline ("centre line", "dashed
    #: line"): a DXF linetype other than continuous, an SVG stroke-dasharray; None for outlines
    construction: str | None = None

    @property
    def start(self) -> Point:
        return self.pieces[0][0]

    @property
    def end(self) -> Point:
        return self.pieces[-1][-1]

    def reversed(self) -> "DrawnPath":
        return DrawnPath([p[::-1] for p in reversed(self.pieces)], self.source, self.closed,
                         self.construction)


@dataclass
class Drawing:
    """A reader's result: the paths, the unit read and converted, entities left out (counted
    by ``(kind, layer)``), and each layer's other names (an SVG layer's id and its Inkscape
    label) for ``--layers``."""

    paths: list[DrawnPath]
    unit_note: str  # e.g. "$INSUNITS 1 (in) -> mm", "width 100mm -> mm", "--scale 0.5 mm"
    ignored: Counter = field(default_factory=Counter)
    layer_names: dict[str, set[str]] = field(default_factory=dict)
    #: the page (an SVG's viewport) as (xmin, ymin, xmax, ymax) in output units; None unknown
    page: tuple[float, float, float, float] | None = None
    #: the layers the drawing's editor marks locked (Inkscape's lock, a DXF layer's lock flag)
    locked: frozenset[str] = frozenset()


def left_out_text(counts: Counter) -> str:
    """``Counter`` of ``(kind, layer)`` (or of kind) as one phrase, largest first:
    ``5 open paths on layer 'Dimensions', 1 TEXT, 1 DIMENSION``."""
    merged: Counter = Counter()
    for key, n in counts.items():
        kind, layer = key if isinstance(key, tuple) else (key, None)
        merged[(kind, layer)] += n
    out = []
    for (kind, layer), n in sorted(merged.items(), key=lambda kv: (-kv[1], kv[0][0],
                                                                   str(kv[0][1]))):
        out.append(f"{n} {_plural(kind) if n > 1 else kind}"
                   + (f" on layer {layer!r}" if layer not in (None, "0") else ""))
    return ", ".join(out)


def _plural(kind: str) -> str:
    """``open path`` -> ``open paths``, ``shape drawn twice`` -> ``shapes drawn twice``; entity
    names (``DIMENSION``) stay as they are."""
    if kind.isupper() or kind.endswith("s"):
        return kind
    words = kind.split(" ")
    k = next((i for i, w in enumerate(words) if w in ("drawn", "of", "on", "not")), len(words)) - 1
    words[k] += "s"
    return " ".join(words)


def distance(p: Point, q: Point) -> float:
    """The Euclidean distance of two points of a drawing (floats, output units)."""
    return math.hypot(p[0] - q[0], p[1] - q[1])


def _decimals(tol: float | None) -> int | None:
    if tol is None or not tol > 0:
        return None
    return max(0, -math.floor(math.log10(tol) + 1e-9))


def fmt_length(x: float, tol: float | None = None) -> str:
    """A length for a message: to the tolerance's precision (``tol`` 0.01: two decimals), else
    to six significant digits."""
    d = _decimals(tol)
    return f"{x:.6g}" if d is None else f"{x:.{d}f}"


def fmt_point(p: Point, tol: float | None = None) -> str:
    """A point for a message, as ``fmt_length`` writes each coordinate."""
    return f"({fmt_length(p[0], tol)}, {fmt_length(p[1], tol)})"
