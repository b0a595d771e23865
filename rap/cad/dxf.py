"""DXF drawings (ezdxf) to drawn paths in the output unit.

``read_dxf(path, unit, tol)`` reads the model space: LINE; ARC; CIRCLE (two half arcs, from 0 and
180 degrees); ELLIPSE (a full one in two halves); SPLINE; LWPOLYLINE and 2D POLYLINE with bulges
(each segment a piece: a line, or the bulge's arc); 3D POLYLINE (straight segments); INSERT
(block references, exploded with ezdxf's ``virtual_entities``, recursively; their entities are
named ``HANDLE.N`` after the INSERT's handle). Curves are flattened with ezdxf's own flattening
(``ConstructionArc.flattening(sagitta)``, ``ConstructionEllipse.flattening(distance)``,
``BSpline.flattening(distance)``) so that no chord is farther than the tolerance from its curve,
in WCS, projected onto the xy-plane. Other entities (TEXT, DIMENSION, HATCH, POINT...) are counted
by layer and left out. An entity drawn in a linetype other than continuous (its own, or its
layer's: CENTER, HIDDEN, PHANTOM, DASHED...) is marked construction (``DrawnPath.construction``):
drafting draws centre lines and hidden edges that way, never a part's outline.

Units: ``$INSUNITS`` converts to the output unit (``ezdxf.units.conversion_factor``); a unitless
drawing (``$INSUNITS`` 0) is read as already in the output unit (the convention of a cutting
drawing at 1:1). Closed entities (closed polylines, circles, full ellipses, closed splines) are
loops; the rest is joined into loops by ``rap.cad.loops.join_loops``. Errors: a file that is not
a DXF, or that ezdxf cannot read, is a ``Problem`` of one line. Cost: linear in the entities and
the flattened points.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

from rap.cad.drawing import Drawing, DrawnPath, Point, Problem, Source

__all__ = ["read_dxf", "UNIT_CODES"]

#: output units as DXF $INSUNITS codes
UNIT_CODES = {"in": 1, "mm": 4, "cm": 5, "m": 6}


def _xy(points, factor: float) -> list[Point]:
    return [(float(p[0]) * factor, float(p[1]) * factor) for p in points]


def _ends(pts: list[Point], start: Point, end: Point) -> list[Point]:
    """The flattened points of a piece with its ends set exactly to its vertices."""
    if math.dist(pts[0], start) > math.dist(pts[-1], start):
        pts = pts[::-1]
    return [start, *pts[1:-1], end]


def _bulged(vertices: list[tuple[float, float, float]], closed: bool, to_wcs, factor: float,
            sagitta: float) -> list[list[Point]]:
    """Pieces of a polyline given as (x, y, bulge) in OCS; ``to_wcs`` maps OCS points to WCS."""
    from ezdxf.math import ConstructionArc, Vec2, bulge_to_arc

    n = len(vertices)
    pieces = []
    for i in range(n if closed else n - 1):
        x0, y0, bulge = vertices[i]
        x1, y1, _ = vertices[(i + 1) % n]
        if (x0, y0) == (x1, y1):
            continue
        start, end = _xy(to_wcs([(x0, y0)]), factor)[0], _xy(to_wcs([(x1, y1)]), factor)[0]
        if bulge:
            center, a0, a1, r = bulge_to_arc(Vec2(x0, y0), Vec2(x1, y1), bulge)
            arc = ConstructionArc(center, r, math.degrees(a0), math.degrees(a1))
            pts = _xy(to_wcs(list(arc.flattening(sagitta))), factor)
            pieces.append(_ends(pts, start, end) if len(pts) > 2 else [start, end])
        else:
            pieces.append([start, end])
    return pieces


def _ocs_mapper(entity, elevation: float = 0.0):
    ocs = entity.ocs()

    def to_wcs(points):
        from ezdxf.math import Vec3

        return list(ocs.points_to_wcs([Vec3(p[0], p[1], elevation) for p in points]))

    return to_wcs


def _paths_of(e, src: Source, factor: float, sagitta: float) -> list[DrawnPath] | None:
    """The drawn paths of one entity; None for an entity type that is left out."""
    from ezdxf.math import ConstructionArc, ConstructionEllipse

    kind = e.dxftype()
    if kind == "LINE":
        s, t = _xy([e.dxf.start, e.dxf.end], factor)
        return [DrawnPath([[s, t]], src, False)] if s != t else []
    if kind == "ARC":
        pts = _xy(list(e.flattening(sagitta)), factor)
        return [DrawnPath([pts], src, False)] if len(pts) >= 2 else []
    if kind == "CIRCLE":
        to_wcs = _ocs_mapper(e, e.dxf.center.z)
        c, r = e.dxf.center, abs(e.dxf.radius)
        if r == 0:
            return []
        halves = [_xy(to_wcs(list(ConstructionArc((c.x, c.y), r, a, a + 180).flattening(sagitta))),
                      factor) for a in (0, 180)]
        halves[1][0], halves[1][-1] = halves[0][-1], halves[0][0]
        return [DrawnPath(halves, src, True)]
    if kind == "ELLIPSE":
        ct = e.construction_tool()
        span = (ct.end_param - ct.start_param) % math.tau
        if span == 0 or math.isclose(span, math.tau):  # a full ellipse: two halves
            halves = []
            for s0 in (ct.start_param, ct.start_param + math.pi):
                half = ConstructionEllipse(ct.center, ct.major_axis, ct.extrusion, ct.ratio, s0,
                                           s0 + math.pi)
                halves.append(_xy(list(half.flattening(sagitta)), factor))
            halves[1][0], halves[1][-1] = halves[0][-1], halves[0][0]
            return [DrawnPath(halves, src, True)]
        return [DrawnPath([_xy(list(ct.flattening(sagitta)), factor)], src, False)]
    if kind == "SPLINE":
        pts = _xy(list(e.construction_tool().flattening(sagitta)), factor)
        closed = bool(e.closed) or pts[0] == pts[-1]
        if closed and pts[0] != pts[-1]:
            pts.append(pts[0])
        return [DrawnPath([pts], src, closed)] if len(pts) >= 2 else []
    if kind == "LWPOLYLINE":
        verts = [(float(x), float(y), float(b)) for x, y, b in e.get_points("xyb")]
        pieces = _bulged(verts, bool(e.closed), _ocs_mapper(e, e.dxf.elevation), factor, sagitta)
        return [DrawnPath(pieces, src, bool(e.closed))] if pieces else []
    if kind == "POLYLINE":
        if e.is_2d_polyline:
            verts = [(float(v.dxf.location.x), float(v.dxf.location.y), float(v.dxf.bulge))
                     for v in e.vertices]
            z = e.dxf.elevation.z if e.dxf.hasattr("elevation") else 0.0
            pieces = _bulged(verts, e.is_closed, _ocs_mapper(e, z), factor, sagitta)
        elif e.is_3d_polyline:
            pts = _xy(list(e.points_in_wcs()), factor)
            if e.is_closed:
                pts.append(pts[0])
            pieces = [[a, b] for a, b in zip(pts, pts[1:]) if a != b]
        else:
            return None  # meshes, polyface
        return [DrawnPath(pieces, src, e.is_closed)] if pieces else []
    return None


#: linetypes of outlines: the rest (centre, hidden, phantom, dashed...) mark construction
CONTINUOUS = frozenset({"", "CONTINUOUS", "BYLAYER", "BYBLOCK"})
_KINDS = (("CENT", "centre line"), ("HIDDEN", "hidden line"), ("PHANTOM", "phantom line"),
          ("DASH", "dashed line"), ("DOT", "dotted line"))


def _linetype(doc, entity, layer: str) -> str:
    """The entity's linetype, ``BYLAYER`` resolved through its layer's table entry."""
    name = str(entity.dxf.get("linetype", "BYLAYER") or "BYLAYER")
    if name.upper() == "BYLAYER":
        try:
            name = str(doc.layers.get(layer).dxf.get("linetype", "CONTINUOUS"))
        except Exception:  # a layer missing from the table: drawn continuous
            name = "CONTINUOUS"
    return name


def _construction(linetype: str) -> str | None:
    """What a non-continuous linetype marks (drafting's chain and dashed lines: centre lines,
    hidden edges), or None for an outline's continuous line."""
    up = linetype.upper()
    if up in CONTINUOUS:
        return None
    for key, kind in _KINDS:
        if key in up:
            return kind
    return f"{linetype} line"


def read_dxf(path: str | Path, unit: str, tol: float) -> Drawing:
    """The drawn paths of a DXF file's model space in ``unit`` (see the module doc)."""
    import ezdxf
    from ezdxf import units as dxf_units

    try:
        doc = ezdxf.readfile(str(path))
    except OSError as exc:
        if exc.errno is None:  # ezdxf's "File ... is not a DXF file."
            raise Problem("not a DXF file (ezdxf cannot read it)") from None
        raise Problem(f"cannot read: {exc.strerror or exc}") from None
    except (ezdxf.DXFError, ValueError, UnicodeError, EOFError) as exc:
        line = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]
        raise Problem(f"not a readable DXF file ({line})") from None
    code = int(doc.header.get("$INSUNITS", 0) or 0)
    if code == 0:
        factor, note = 1.0, f"$INSUNITS 0 (unitless): read as {unit}"
    else:
        try:
            factor = float(dxf_units.conversion_factor(code, UNIT_CODES[unit]))
            name = dxf_units.unit_name(code)
        except (KeyError, ValueError, IndexError):
            raise Problem(f"$INSUNITS {code}: not a unit of length that can be converted to "
                          f"{unit}") from None
        note = f"$INSUNITS {code} ({name})" + (f" -> {unit}" if factor != 1 else "")
    if not (factor > 0 and math.isfinite(factor)):
        raise Problem(f"$INSUNITS {code}: no conversion to {unit}")
    sagitta = tol / factor
    paths: list[DrawnPath] = []
    ignored: Counter = Counter()
    order = 0

    def visit(entity, ident: str, depth: int, inherited: str | None = None) -> None:
        nonlocal order
        order += 1
        kind = entity.dxftype()
        layer = entity.dxf.get("layer", "0")
        if layer == "0" and inherited is not None:
            layer = inherited  # a block's layer-0 entities take the INSERT's layer
        if kind == "INSERT":
            if depth > 16:
                raise Problem(f"INSERT {ident}: blocks nested more than 16 deep")
            for k, sub in enumerate(entity.virtual_entities()):
                visit(sub, f"{ident}.{k + 1}", depth + 1, layer)
            return
        src = Source("dxf", kind, ident, layer, order)
        try:
            got = _paths_of(entity, src, factor, sagitta)
        except (ValueError, ZeroDivisionError, ArithmeticError) as exc:
            raise Problem(f"{src.describe()}: cannot be read ({exc})") from None
        if got is None:
            ignored[(kind, layer)] += 1
            return
        construction = _construction(_linetype(doc, entity, layer))
        for path in got:
            path.construction = construction
        paths.extend(got)

    for entity in doc.modelspace():
        visit(entity, str(entity.dxf.handle), 0)
    locked = frozenset(layer.dxf.name for layer in doc.layers if layer.is_locked())
    return Drawing(paths, note, ignored, locked=locked)
