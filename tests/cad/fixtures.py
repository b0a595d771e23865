"""Named tiny drawings for the CAD import tests: DXF files written with ezdxf, SVG files by hand,
and drawn paths (no files) for the loop, ring and part builders.

Each ``dxf_*`` function writes its drawing to ``tmp_path / NAME.dxf`` and returns the path.
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import ezdxf

from rap.cad.drawing import DrawnPath, Source
from rap.cad.loops import join_loops
from rap.cad.rings import exact_rings
from rap.cad.snap import Grid

MM, INCH, UNITLESS = 4, 1, 0


def _doc(units: int = MM):
    doc = ezdxf.new("R2010", units=units)
    return doc, doc.modelspace()


def _save(doc, tmp: Path, name: str) -> Path:
    path = Path(tmp) / f"{name}.dxf"
    doc.saveas(path)
    return path


def dxf_bulged_pair(tmp: Path) -> Path:
    """Two 10 x 10 squares side by side (layers A, B) whose shared edge x = 10 bulges into B:
    a bulge of 0.3 drawn on A's polyline upwards and of -0.3 on B's downwards."""
    doc, msp = _doc()
    msp.add_lwpolyline([(0, 0, 0), (10, 0, 0.3), (10, 10, 0), (0, 10, 0)], format="xyb",
                       close=True, dxfattribs={"layer": "A"})
    msp.add_lwpolyline([(10, 0, 0), (20, 0, 0), (20, 10, 0), (10, 10, -0.3)], format="xyb",
                       close=True, dxfattribs={"layer": "B"})
    return _save(doc, tmp, "bulged_pair")


def dxf_arc_chains(tmp: Path) -> Path:
    """Two parts of loose LINE and ARC entities sharing a half circle of radius 5 centred at
    (10, 5): A (layer A) is the square 0..10 with the half disc x >= 10 added (its ARC drawn from
    -90 to 90 degrees); B (layer B) is the square 10..20 less that half disc (its ARC drawn as
    the same arc, a separate entity). Lines are drawn in scrambled directions."""
    doc, msp = _doc()
    a = {"layer": "A"}
    msp.add_line((0, 0), (10, 0), dxfattribs=a)
    msp.add_arc((10, 5), 5, -90, 90, dxfattribs=a)
    msp.add_line((0, 10), (10, 10), dxfattribs=a)
    msp.add_line((0, 10), (0, 0), dxfattribs=a)
    b = {"layer": "B"}
    msp.add_line((20, 0), (10, 0), dxfattribs=b)
    msp.add_line((20, 0), (20, 10), dxfattribs=b)
    msp.add_line((10, 10), (20, 10), dxfattribs=b)
    msp.add_arc((10, 5), 5, 270, 90, dxfattribs=b)
    return _save(doc, tmp, "arc_chains")


def dxf_split_hole(tmp: Path) -> Path:
    """A plate (layer plate) with a CIRCLE hole of radius 3 at (10, 10), split at 0 and 180
    degrees, filled by two half discs (layers left, right) cut along the vertical diameter: each
    a polyline with a bulge of 1 (a half circle), so the two sides of the circle are split at
    different points (a T-junction on a curve)."""
    doc, msp = _doc()
    msp.add_lwpolyline([(0, 0), (20, 0), (20, 20), (0, 20)], close=True,
                       dxfattribs={"layer": "plate"})
    msp.add_circle((10, 10), 3, dxfattribs={"layer": "plate"})
    msp.add_lwpolyline([(10, 13, 1), (10, 7, 0)], format="xyb", close=True,
                       dxfattribs={"layer": "left"})
    msp.add_lwpolyline([(10, 7, 1), (10, 13, 0)], format="xyb", close=True,
                       dxfattribs={"layer": "right"})
    return _save(doc, tmp, "split_hole")


def dxf_t_junction(tmp: Path) -> Path:
    """A quadrilateral A whose slanted right edge runs from (10, 0) to (13, 9); B and C touch
    it along its lower and upper thirds, with a vertex at (11, 3) and (12, 6) on it; the edge
    of A is one segment."""
    doc, msp = _doc()
    msp.add_lwpolyline([(0, 0), (10, 0), (13, 9), (0, 9)], close=True, dxfattribs={"layer": "A"})
    msp.add_lwpolyline([(10, 0), (20, 0), (20, 3), (11, 3)], close=True, dxfattribs={"layer": "B"})
    msp.add_lwpolyline([(11, 3), (20, 3), (20, 6), (12, 6)], close=True, dxfattribs={"layer": "C"})
    msp.add_lwpolyline([(12, 6), (20, 6), (20, 9), (13, 9)], close=True, dxfattribs={"layer": "D"})
    return _save(doc, tmp, "t_junction")


def dxf_spline_pair(tmp: Path) -> Path:
    """Two parts sharing a SPLINE edge from (10, 0) to (10, 10), drawn once per part (the second
    with its control points reversed) and closed with lines."""
    doc, msp = _doc()
    ctrl = [(10, 0), (14, 3), (6, 7), (10, 10)]
    a, b = {"layer": "A"}, {"layer": "B"}
    msp.add_spline(ctrl, dxfattribs=a)
    msp.add_line((10, 10), (0, 10), dxfattribs=a)
    msp.add_line((0, 10), (0, 0), dxfattribs=a)
    msp.add_line((0, 0), (10, 0), dxfattribs=a)
    msp.add_spline(ctrl[::-1], dxfattribs=b)
    msp.add_line((10, 0), (20, 0), dxfattribs=b)
    msp.add_line((20, 0), (20, 10), dxfattribs=b)
    msp.add_line((20, 10), (10, 10), dxfattribs=b)
    return _save(doc, tmp, "spline_pair")


def dxf_holes(tmp: Path) -> Path:
    """One layer 'plate': a 30 x 20 outline with a circular hole (r 2 at (5, 5)) and a
    rectangular hole (20..25 x 10..15); a peg (layer peg) fills the rectangular hole exactly."""
    doc, msp = _doc()
    p = {"layer": "plate"}
    msp.add_lwpolyline([(0, 0), (30, 0), (30, 20), (0, 20)], close=True, dxfattribs=p)
    msp.add_circle((5, 5), 2, dxfattribs=p)
    msp.add_lwpolyline([(20, 10), (25, 10), (25, 15), (20, 15)], close=True, dxfattribs=p)
    msp.add_lwpolyline([(20, 10), (25, 10), (25, 15), (20, 15)], close=True,
                       dxfattribs={"layer": "peg"})
    return _save(doc, tmp, "holes")


def dxf_square(tmp: Path, units: int, side: float = 1.0, name: str = "square") -> Path:
    doc, msp = _doc(units)
    msp.add_lwpolyline([(0, 0), (side, 0), (side, side), (0, side)], close=True)
    return _save(doc, tmp, name)


def dxf_ellipse_and_block(tmp: Path) -> Path:
    """A full ELLIPSE (layer E) and a block of a 2 x 1 rectangle inserted twice (layer K)."""
    doc, msp = _doc()
    msp.add_ellipse((0, 0), major_axis=(4, 0), ratio=0.5, dxfattribs={"layer": "E"})
    blk = doc.blocks.new("BRICK")
    blk.add_lwpolyline([(0, 0), (2, 0), (2, 1), (0, 1)], close=True)
    msp.add_blockref("BRICK", (10, 0), dxfattribs={"layer": "K"})
    msp.add_blockref("BRICK", (12, 0), dxfattribs={"layer": "K"})
    return _save(doc, tmp, "ellipse_block")


def dxf_small_gap(tmp: Path, gap: float = 0.004) -> Path:
    """A triangle of three LINEs whose last line stops ``gap`` short of the first's start."""
    doc, msp = _doc()
    msp.add_line((0, 0), (10, 0))
    msp.add_line((10, 0), (0, 10))
    msp.add_line((0, 10), (0, gap))
    return _save(doc, tmp, "small_gap")


def dxf_seven(tmp: Path) -> Path:
    """Seven parts with arcs: a U tray, three blocks in its pocket whose joints are arcs
    (bulges drawn from both sides), a cap over them and two discs (CIRCLEs) resting on it."""
    doc, msp = _doc()

    def poly(points, layer):
        msp.add_lwpolyline(points, format="xyb", close=True, dxfattribs={"layer": layer})

    # tray: outer 0..40 x 0..15 with a pocket 5..35 x 5..15
    poly([(0, 0, 0), (40, 0, 0), (40, 15, 0), (35, 15, 0), (35, 5, 0), (5, 5, 0), (5, 15, 0),
          (0, 15, 0)], "tray")
    # three blocks in the pocket; joints at x = 15 and x = 25 bulge (+x on the way up)
    poly([(5, 5, 0), (15, 5, 0.25), (15, 15, 0), (5, 15, 0)], "b1")
    poly([(15, 5, 0), (25, 5, 0.25), (25, 15, 0), (15, 15, -0.25)], "b2")
    poly([(25, 5, 0), (35, 5, 0), (35, 15, 0), (25, 15, -0.25)], "b3")
    # a cap over the pocket
    poly([(0, 15, 0), (40, 15, 0), (40, 20, 0), (0, 20, 0)], "cap")
    # two discs resting on the cap
    msp.add_circle((10, 23), 3, dxfattribs={"layer": "d1"})
    msp.add_circle((30, 23), 3, dxfattribs={"layer": "d2"})
    return _save(doc, tmp, "seven")


SVG_TOUCHING_ARC = """<svg xmlns="http://www.w3.org/2000/svg"
     width="20mm" height="10mm" viewBox="0 0 20 10">
  <path id="a" d="M 0 0 L 10 0 A 5 5 0 0 1 10 10 L 0 10 Z"/>
  <path id="b" d="M 20 0 L 20 10 L 10 10 A 5 5 0 0 0 10 0 Z"/>
</svg>
"""
"""Two parts sharing a half circle through (10, 0), (15, 5), (10, 10) (SVG y down): 'a' bulges
into 'b'; each draws the arc in its own direction."""

SVG_INCH_TRANSFORMS = """<svg xmlns="http://www.w3.org/2000/svg"
     width="2in" height="1in" viewBox="0 0 200 100">
  <g id="layer1" transform="translate(100, 0)">
    <rect id="sq" x="0" y="0" width="50" height="50" transform="rotate(90, 25, 25)"/>
  </g>
  <circle id="disc" cx="25" cy="25" r="25"/>
  <path id="ring" d="M 150 60 h 40 v 40 h -40 z M 160 70 v 20 h 20 v -20 z"/>
</svg>
"""
"""100 user units per inch: 'sq' is a 0.5 in square at x 1..1.5 in, 'disc' a disc of radius
0.25 in, 'ring' a 0.4 in square with a 0.2 in square hole (two subpaths of one path)."""

SVG_UNITLESS = """<svg xmlns="http://www.w3.org/2000/svg"
     width="200" height="100" viewBox="0 0 100 50">
  <rect id="r" x="0" y="0" width="10" height="5"/>
</svg>
"""

SVG_LAYERS = """<svg xmlns="http://www.w3.org/2000/svg"
     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="30mm" height="10mm" viewBox="0 0 30 10">
  <g inkscape:groupmode="layer" inkscape:label="frame">
    <rect x="0" y="0" width="10" height="10"/>
    <circle cx="5" cy="5" r="2"/>
  </g>
  <g id="block">
    <polyline points="10,0 20,0 20,10"/>
    <polyline points="20,10 10,10 10,0"/>
  </g>
</svg>
"""
"""Two layers: 'frame' (a square and a circle inside it, two elements: one part with a hole
with --parts layer) and 'block' (a square drawn as two open polylines, joined)."""


def write(tmp: Path, name: str, text: str) -> Path:
    path = Path(tmp) / name
    path.write_text(text, encoding="utf-8")
    return path


def area(part) -> Fraction:
    """A part's exact area (outline less holes)."""
    return abs(part.area())


# -- drawn paths (no files) ----------------------------------------------------------------------

GRID = Grid.parse("0.01")


def src(name: str, order: int = 0, layer: str = "0") -> Source:
    return Source("dxf", "LWPOLYLINE", name, layer, order)


def polygon(points, name, order=0, layer="0") -> DrawnPath:
    """A closed path of straight pieces."""
    n = len(points)
    return DrawnPath([[points[i], points[(i + 1) % n]] for i in range(n)], src(name, order, layer),
                     True)


def arc(cx, cy, r, a0, a1, n) -> list:
    return [(cx + r * math.cos(a0 + (a1 - a0) * k / n), cy + r * math.sin(a0 + (a1 - a0) * k / n))
            for k in range(n + 1)]


def rings_of(paths, grid=GRID):
    return exact_rings(join_loops(paths, grid.step_float, "mm"), grid, "mm")
