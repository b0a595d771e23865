"""SVG drawings (svgelements) to drawn paths in the output unit, y up.

Why svgelements: it is a pure-Python, dependency-free, maintained parser that implements the
parts of SVG 1.1/2 a drawing needs (paths with every command, the basic shapes rect with rounded
corners, circle, ellipse, line, polyline, polygon; nested ``transform`` attributes, ``<use>``,
CSS ``display``, ``viewBox`` with ``preserveAspectRatio``, lengths with units) and hands back each
shape as segments (line, quadratic and cubic Bezier, elliptical arc) with the transforms applied
(``reify``). svgpathtools parses path data only (no shapes, no transforms of groups), and
cairosvg/librsvg render rather than parse.

Units: a document whose root ``width`` or ``height`` carries a physical unit (mm, cm, in, pt, pc,
Q) is converted exactly: svgelements maps the viewBox onto the viewport in CSS pixels (96 per
inch, with its own constants per unit), and the reader divides by the same constant, so
``width="100mm" viewBox="0 0 100 50"`` gives 1 mm per user unit. A document with no physical
width or height (no unit, or px) is refused, unless ``scale`` gives the output units per SVG user
unit (then the viewBox mapping is undone first). Curves are flattened so that no chord is farther
than the tolerance from its curve: Beziers with the uniform step the bound on their second
derivative gives, elliptical arcs with the step the largest radius gives.

Parts: each closed subpath is a loop; open subpaths are joined into loops within their top-level
group (``rap.cad.loops.join_loops``). Sources name the element by its id (``<path id='p1'>``), its
top-level ``<g>`` (its id, else its ``inkscape:label``) is its layer. Cost: linear in the segments
and the flattened points.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from pathlib import Path

from rap.cad.drawing import UNITS_MM, Drawing, DrawnPath, Point, Problem, Source

__all__ = ["read_svg", "PHYSICAL_MM", "CSS_PX_MM"]

#: physical units of a root width/height, in millimetres
PHYSICAL_MM = {"mm": 1.0, "cm": 10.0, "in": 25.4, "pt": 25.4 / 72, "pc": 25.4 / 6, "q": 0.25}

_LENGTH = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zA-Z%]*)\s*$")
#: a CSS pixel (SVG's user unit when the document states no physical size), in millimetres
CSS_PX_MM = 25.4 / 96
_MAX_STEPS = 4096  # chords per segment (a curve this fine needs a coarser tolerance)


def _physical(text) -> str | None:
    m = _LENGTH.match(str(text)) if text is not None else None
    if m and m.group(2).lower() in PHYSICAL_MM:
        return m.group(2)
    return None


def _pixels(text) -> bool:
    """Is a root width or height a length in CSS px (a bare number, or ``px``)?"""
    m = _LENGTH.match(str(text)) if text is not None else None
    return bool(m) and m.group(2).lower() in ("", "px")


class _Affine:
    """x' = a x + c y + e, y' = b x + d y + f."""

    def __init__(self, a, b, c, d, e, f):
        self.m = (float(a), float(b), float(c), float(d), float(e), float(f))

    def __call__(self, p) -> Point:
        a, b, c, d, e, f = self.m
        x, y = float(p[0]), float(p[1])
        return (a * x + c * y + e, b * x + d * y + f)

    def norm(self) -> float:
        a, b, c, d, _, _ = self.m
        return max(abs(a) + abs(c), abs(b) + abs(d))


def _steps(bound: float, tol: float) -> int:
    return max(1, min(_MAX_STEPS, math.ceil(math.sqrt(bound / tol)) if bound > 0 else 1))


def _bezier(ctrl: list[Point], tol: float) -> list[Point]:
    """A quadratic or cubic Bezier (output coordinates) as chords within ``tol``: with n uniform
    steps the chord error is at most max|B''| / (8 n^2)."""
    def d2(p, q, r):
        return math.hypot(p[0] - 2 * q[0] + r[0], p[1] - 2 * q[1] + r[1])

    if len(ctrl) == 3:
        n = _steps(2 * d2(*ctrl) / 8, tol)
        p0, p1, p2 = ctrl

        def at(t):
            u = 1 - t
            return (u * u * p0[0] + 2 * u * t * p1[0] + t * t * p2[0],
                    u * u * p0[1] + 2 * u * t * p1[1] + t * t * p2[1])
    else:
        n = _steps(6 * max(d2(*ctrl[:3]), d2(*ctrl[1:])) / 8, tol)
        p0, p1, p2, p3 = ctrl

        def at(t):
            u = 1 - t
            return (u ** 3 * p0[0] + 3 * u * u * t * p1[0] + 3 * u * t * t * p2[0] + t ** 3 * p3[0],
                    u ** 3 * p0[1] + 3 * u * u * t * p1[1] + 3 * u * t * t * p2[1] + t ** 3 * p3[1])
    return [ctrl[0], *(at(k / n) for k in range(1, n)), ctrl[-1]]


def _arc(seg, T: _Affine, tol: float) -> list[Point]:
    r = max(abs(float(seg.rx)), abs(float(seg.ry))) * T.norm()
    sweep = abs(float(seg.sweep))
    if r <= tol / 2 or sweep == 0:
        n = 1
    else:
        n = max(1, min(_MAX_STEPS, math.ceil(sweep / (2 * math.acos(1 - tol / r)))))
    return [T(seg.start), *(T(seg.point(k / n)) for k in range(1, n)), T(seg.end)]


def _subpaths(shape, T: _Affine, tol: float) -> list[tuple[list[list[Point]], bool]]:
    """(pieces, closed) of each subpath of a shape."""
    import svgelements as se

    out: list[tuple[list[list[Point]], bool]] = []
    pieces: list[list[Point]] = []
    start = None

    def flush(closed: bool) -> None:
        nonlocal pieces
        if pieces:
            out.append((pieces, closed))
        pieces = []

    for seg in shape.segments():
        if isinstance(seg, se.Move):
            flush(False)
            start = T(seg.end)
            continue
        if seg.start is None or seg.end is None:
            continue
        if isinstance(seg, se.Close):
            a, b = T(seg.start), start if start is not None else T(seg.end)
            if a != b:
                pieces.append([a, b])
            flush(True)
            continue
        if isinstance(seg, se.Line):
            pts = [T(seg.start), T(seg.end)]
        elif isinstance(seg, se.QuadraticBezier):
            pts = _bezier([T(seg.start), T(seg.control), T(seg.end)], tol)
        elif isinstance(seg, se.CubicBezier):
            pts = _bezier([T(seg.start), T(seg.control1), T(seg.control2), T(seg.end)], tol)
        elif isinstance(seg, se.Arc):
            pts = _arc(seg, T, tol)
        else:
            continue
        if pieces:
            pts[0] = pieces[-1][-1]  # consecutive pieces share their point exactly
        if pts[0] != pts[-1] or len(pts) > 2:
            pieces.append(pts)
    flush(False)
    return out


def _layer_name(group, order: int) -> tuple[str, set[str]]:
    """A top-level group's layer name (its id, else its Inkscape label, else ``g<order>``) and
    every name ``--layers`` accepts for it (id and label)."""
    label = None
    for key, value in group.values.items():
        if str(key).endswith("label") and "inkscape" in str(key):
            label = str(value)
            break
    name = label or group.id or f"g{order}"  # the name Inkscape shows in its Layers panel
    return name, {n for n in (name, group.id, label) if n}


def _locked(group) -> bool:
    """Is the layer locked in Inkscape (``sodipodi:insensitive="true"``)?"""
    return any(str(k).endswith("insensitive") and str(v).strip().lower() == "true"
               for k, v in group.values.items())


def _dashed(el) -> bool:
    """Is the element stroked with dashes (a construction or centre line by drafting custom)?"""
    dash = el.values.get("stroke-dasharray")
    return dash is not None and str(dash).strip().lower() not in ("", "none", "0")


#: SVG elements that draw something but no part's outline: counted when left out
_DRAWN_TAGS = frozenset({"text", "image", "tspan", "textPath", "foreignObject", "pattern",
                         "marker", "symbol"})


def read_svg(path: str | Path, unit: str, tol: float, scale: float | None = None) -> Drawing:
    """The drawn paths of an SVG file in ``unit`` (see the module doc)."""
    import xml.etree.ElementTree as ET

    import svgelements as se

    try:
        svg = se.SVG.parse(str(path), reify=True, ppi=96.0)
    except OSError as exc:
        raise Problem(f"cannot read: {exc.strerror or exc}") from None
    except (ET.ParseError, ValueError, TypeError, AttributeError, IndexError) as exc:
        line = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]
        raise Problem(f"not a readable SVG file ({line})") from None
    width, height = svg.values.get("width"), svg.values.get("height")
    physical = _physical(width) or _physical(height)
    if scale is not None:
        if not (scale > 0 and math.isfinite(scale)):
            raise Problem(f"--scale {scale}: must be a positive number")
        vb = se.Matrix(svg.viewbox_transform) if svg.viewbox_transform else se.Matrix()
        inv = ~vb
        T = _Affine(scale * inv.a, -scale * inv.b, scale * inv.c, -scale * inv.d, scale * inv.e,
                    -scale * inv.f)
        note = f"--scale {scale:g} {unit} per SVG user unit"
    elif physical:
        px = float(se.Length(f"1{physical}").value(ppi=96.0))
        f = PHYSICAL_MM[physical.lower()] / px / UNITS_MM[unit]
        T = _Affine(f, 0, 0, -f, 0, 0)
        note = f"width {width}, height {height}" + ("" if physical == unit else f" -> {unit}")
    elif _pixels(width) or _pixels(height):  # a size in CSS px: 96 per inch
        f = CSS_PX_MM / UNITS_MM[unit]
        T = _Affine(f, 0, 0, -f, 0, 0)
        note = (f"width {width}, height {height} in CSS px (no physical unit): 1 px read as "
                f"{f:.6g} {unit} (--scale to change)")
    else:  # no size at all (or a percentage): a user unit is a CSS px
        vb = se.Matrix(svg.viewbox_transform) if svg.viewbox_transform else se.Matrix()
        inv = ~vb
        f = CSS_PX_MM / UNITS_MM[unit]
        T = _Affine(f * inv.a, -f * inv.b, f * inv.c, -f * inv.d, f * inv.e, -f * inv.f)
        note = (f"no physical width or height ({width!r}): a user unit read as a CSS px, "
                f"{f:.6g} {unit} (--scale to change)")
    paths: list[DrawnPath] = []
    ignored: Counter = Counter()
    names: dict[str, set[str]] = {}
    locked: set[str] = set()
    order = 0

    def walk(group, layer: str | None) -> None:
        nonlocal order
        for el in group:
            order += 1
            if isinstance(el, se.Group):
                if layer is None:
                    name, aliases = _layer_name(el, order)
                    names[name] = aliases
                    if _locked(el):
                        locked.add(name)
                    walk(el, name)
                else:
                    walk(el, layer)
            elif isinstance(el, se.Use):  # a clone: svgelements resolved it, transforms applied
                walk(el, layer)
            elif isinstance(el, se.Shape):
                tag = str(el.values.get("tag", type(el).__name__.lower()))
                ident = el.id if el.id else None
                dashed = _dashed(el)
                for k, (pieces, closed) in enumerate(_subpaths(el, T, tol)):
                    paths.append(DrawnPath(pieces, Source("svg", tag, ident, layer, order, k),
                                           closed, "dashed line" if dashed else None))
            elif not isinstance(el, se.SVG):
                tag = str(getattr(el, "values", {}).get("tag", type(el).__name__.lower()))
                if tag in _DRAWN_TAGS:  # metadata, namespaced editor data: not drawing at all
                    ignored[(tag, layer)] += 1

    walk(svg, None)
    return Drawing(paths, note, ignored, names, _page(svg, T), frozenset(locked))


def _page(svg, T: _Affine) -> tuple[float, float, float, float] | None:
    """The viewport's box in output units (the page a person sees the drawing on)."""
    try:
        w, h = float(svg.width), float(svg.height)
    except (TypeError, ValueError):
        return None
    if not (w > 0 and h > 0 and math.isfinite(w) and math.isfinite(h)):
        return None
    (x0, y0), (x1, y1) = T((0.0, 0.0)), T((w, h))
    return (min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))
