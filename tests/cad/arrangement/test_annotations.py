"""Drawings as people make them (fixtures written here, one of each kind): a jigsaw sheet of
shared cut lines, an Inkscape file with a dimension layer and a target outline, clones, a
SolidWorks-style DXF with its scale symbol and a DIMENSION, splines. Each is checked for the
number of parts and their total area against what a person sees."""

from __future__ import annotations

from fractions import Fraction

import pytest

from rap.cad import DrawingError, ImportOptions, import_drawing
from rap.errors import InputError
from tests.cad import fixtures as F

# a 30 x 20 mm sheet: a border and cut lines drawn once, ending on the border (T-junctions) and
# crossing each other: six 10 x 10 pieces
SVG_CUT_SHEET = """<svg xmlns="http://www.w3.org/2000/svg" width="30mm" height="20mm"
     viewBox="0 0 30 20">
  <rect id="border" x="0" y="0" width="30" height="20" fill="none" stroke="red"/>
  <path id="cuts" fill="none" stroke="red" d="M 10 0 L 10 20 M 20 0 L 20 20 M 0 10 L 30 10"/>
</svg>
"""

# Inkscape: the parts' layer (two touching squares), a dimension layer (open lines and text) and
# a target outline of the parts' union, slightly off as hand-drawn outlines are
SVG_INKSCAPE = """<svg xmlns="http://www.w3.org/2000/svg"
     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="100mm" height="100mm" viewBox="0 0 100 100">
  <metadata><rdf xmlns="http://www.w3.org/1999/02/22-rdf-syntax-ns#"/></metadata>
  <g inkscape:groupmode="layer" id="layer1" inkscape:label="Parts">
    <rect id="a" x="10" y="10" width="20" height="20"/>
    <rect id="b" x="30" y="10" width="20" height="20"/>
  </g>
  <g inkscape:groupmode="layer" id="layer2" inkscape:label="Dimensions">
    <path id="d1" d="M 10 40 L 50 40" stroke="black"/>
    <path id="d2" d="M 10 38 L 10 42 M 50 38 L 50 42" stroke="black"/>
    <path id="d3" d="M 5 10 L 5 30" stroke="black" stroke-dasharray="2,1"/>
    <text x="25" y="45">40 mm</text>
  </g>
  <g inkscape:groupmode="layer" id="layer3" inkscape:label="Outline">
    <path id="outline" d="M 10.05 9.95 L 50.05 10.02 L 49.97 30.04 L 9.98 30.01 Z"/>
  </g>
</svg>
"""

# clones: a tile in <defs>, used three times with transforms, side by side
SVG_CLONES = """<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
     width="60mm" height="20mm" viewBox="0 0 60 20">
  <defs><path id="tile" d="M 0 0 L 20 0 L 20 20 L 0 20 Z"/></defs>
  <g transform="translate(0,0)">
    <use xlink:href="#tile"/>
    <use href="#tile" transform="translate(20,0)"/>
    <use href="#tile" transform="translate(60,20) rotate(180)"/>
  </g>
</svg>
"""


def _solidworks_dxf(tmp):
    """A SolidWorks-style sheet: a 40 x 20 plate with a round hole and a 10 x 10 peg apart,
    then the scale symbol (a 10 mm box of LINEs crossed by two CENTERX2 lines), its POINT and a
    DIMENSION, all on layer 0."""
    doc, msp = F._doc()
    if "CENTERX2" not in doc.linetypes:
        doc.linetypes.add("CENTERX2", pattern=[2.0, 1.25, -0.25, 0.25, -0.25])
    msp.add_lwpolyline([(0, 0), (40, 0), (40, 20), (0, 20)], close=True)
    msp.add_circle((10, 10), 3)
    msp.add_lwpolyline([(50, 0), (60, 0), (60, 10), (50, 10)], close=True)
    for a, b in (((100, 0), (110, 0)), ((110, 0), (110, 10)), ((110, 10), (100, 10)),
                 ((100, 10), (100, 0))):
        msp.add_line(a, b)
    msp.add_line((105, 0), (105, 10), dxfattribs={"linetype": "CENTERX2"})
    msp.add_line((100, 5), (110, 5), dxfattribs={"linetype": "CENTERX2"})
    msp.add_point((105, 5))
    msp.add_linear_dim(base=(100, -5), p1=(100, 5), p2=(110, 5)).render()
    return F._save(doc, tmp, "solidworks")


def _spline_dxf(tmp):
    """Two parts sharing a spline edge (each drawn with its own copy of the spline) and a
    closed spline part apart."""
    doc, msp = F._doc()
    fit = [(10, 0), (12, 5), (8, 10), (10, 20)]
    for layer, corner in (("L", 0), ("R", 20)):
        msp.add_line((corner, 0), (10, 0), dxfattribs={"layer": layer})
        msp.add_line((corner, 20), (10, 20), dxfattribs={"layer": layer})
        msp.add_line((corner, 0), (corner, 20), dxfattribs={"layer": layer})
        msp.add_spline(fit, dxfattribs={"layer": layer})
    msp.add_spline([(40, 0), (50, 5), (40, 10), (30, 5), (40, 0)],
                   dxfattribs={"layer": "blob"}).closed = True
    return F._save(doc, tmp, "splines")


def _area(result) -> float:
    return sum(float(p.area()) for p in result.assembly.parts)


def test_a_cut_sheet_is_its_faces(tmp_path):
    result = import_drawing(F.write(tmp_path, "sheet.svg", SVG_CUT_SHEET))
    assert result.made_by == "faces" and len(result.assembly) == 6
    assert _area(result) == pytest.approx(600)
    parts = result.assembly.parts
    for p in parts:  # each a 10 x 10 square on the grid, exactly
        assert p.area() == 100 and len(p.outer) == 4
    # shared cut lines: neighbours share their edge's vertices exactly
    corners = [set(p.outer) for p in parts]
    assert sum(len(a & b) == 2 for i, a in enumerate(corners) for b in corners[i + 1:]) == 7


def test_inkscape_dimensions_and_a_target_outline_are_left_out(tmp_path):
    result = import_drawing(F.write(tmp_path, "ink.svg", SVG_INKSCAPE))
    assert sorted(p.id for p in result.assembly.parts) == ["a", "b"]
    assert _area(result) == pytest.approx(800)
    line = result.summary()
    assert "left out:" in line and "open paths on layer 'Dimensions'" in line
    assert "1 dashed line on layer 'Dimensions'" in line and "1 text on layer 'Dimensions'" in line
    assert "1 outline of the parts' union on layer 'Outline'" in line
    assert "metadata" not in line and "rdf" not in line.lower()


def test_layers_are_chosen_by_id_or_label(tmp_path):
    path = F.write(tmp_path, "ink.svg", SVG_INKSCAPE)
    only = import_drawing(path, ImportOptions(layers=("Parts",)))
    assert sorted(p.id for p in only.assembly.parts) == ["a", "b"]
    assert "paths not chosen on layer 'Dimensions'" in only.summary()
    # the outline alone is one part: the user asked for it
    outline = import_drawing(path, ImportOptions(layers=("layer3",)))
    assert [p.id for p in outline.assembly.parts] == ["outline"]
    skipped = import_drawing(path, ImportOptions(skip_layers=("Outline", "Dimensions")))
    assert sorted(p.id for p in skipped.assembly.parts) == ["a", "b"]
    with pytest.raises(InputError, match=r"layers 'Nope': no such layer in the drawing "
                                         r"\(layers: Dimensions, Outline, Parts\)"):
        import_drawing(path, ImportOptions(layers=("Nope",)))


def test_use_clones_are_read_with_their_transforms(tmp_path):
    result = import_drawing(F.write(tmp_path, "clones.svg", SVG_CLONES))
    assert len(result.assembly) == 3 and _area(result) == pytest.approx(1200)
    xs = sorted(min(float(x) for x, _ in p.outer) for p in result.assembly.parts)
    assert xs == [0, 20, 40]


def test_a_solidworks_scale_symbol_and_dimension_are_left_out(tmp_path):
    result = import_drawing(_solidworks_dxf(tmp_path))
    assert len(result.assembly) == 2  # the plate (with its hole) and the peg
    plate = max(result.assembly.parts, key=lambda p: p.area())
    assert len(plate.holes) == 1
    assert _area(result) == pytest.approx(800 - 3.14159 * 9 + 100, rel=1e-3)
    line = result.summary()
    for what in ("1 symbol", "2 centre lines", "1 DIMENSION", "1 POINT"):
        assert what in line, line


def test_splines_shared_by_two_parts_touch_exactly(tmp_path):
    result = import_drawing(_spline_dxf(tmp_path))
    p = {q.id: q for q in result.assembly.parts}
    assert set(p) == {"L", "R", "blob"}
    assert p["L"].area() + p["R"].area() == 400  # no gap, no overlap along the spline
    shared = set(p["L"].outer) & set(p["R"].outer)
    assert len(shared) > 6


def test_an_overlap_names_its_size_and_only_a_tolerance_that_works(tmp_path):
    svg = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm"
         viewBox="0 0 100 100">
      <rect id="a" x="0" y="0" width="20" height="20"/>
      <rect id="b" x="19.97" y="0" width="20" height="20"/>
    </svg>"""
    path = F.write(tmp_path, "thin.svg", svg)
    with pytest.raises(DrawingError, match=r"overlap by 0\.60 mm\^2, 0\.03 mm deep "
                                           r"\(--tolerance (\S+) absorbs the overlaps\)") as e:
        import_drawing(path)
    tolerance = e.value.problem.split("--tolerance ")[1].split(" ")[0]
    fixed = import_drawing(path, ImportOptions(tolerance=tolerance))
    assert len(fixed.assembly) == 2
    deep = F.write(tmp_path, "deep.svg", svg.replace("19.97", "10"))
    with pytest.raises(DrawingError, match=r"overlap by 200\.00 mm\^2, 6\.67 mm deep$"):
        import_drawing(deep)


def test_a_gap_beyond_the_tolerance_names_the_tolerance_that_closes_it(tmp_path):
    with pytest.raises(DrawingError, match=r"is 0\.02 mm: --tolerance 0\.05 closes it"):
        import_drawing(F.dxf_small_gap(tmp_path, 0.02))
    assert import_drawing(F.dxf_small_gap(tmp_path, 0.02),
                          ImportOptions(tolerance="0.05")).gaps_closed == 1


def test_a_t_junction_end_is_not_a_gap(tmp_path):
    # three squares, their shared edges drawn once: the middle line ends on the others' spans
    doc, msp = F._doc()
    for a, b in (((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0)),
                 ((10, 0), (10, 10)), ((10, 5), (20, 5))):
        msp.add_line(a, b)
    result = import_drawing(F._save(doc, tmp_path, "tee"))
    assert len(result.assembly) == 3 and _area(result) == 200
    assert sorted(p.area() for p in result.assembly.parts) == [50, 50, 100]
    assert all(v[0] == Fraction(v[0]) for p in result.assembly.parts for v in p.outer)


def test_a_bar_along_the_whole_page_is_page_furniture_not_a_part(tmp_path):
    svg = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm"
         viewBox="0 0 100 50">
      <rect id="a" x="10" y="10" width="20" height="20"/>
      <rect id="b" x="30" y="10" width="20" height="20"/>
      <rect id="bar" x="0" y="45" width="100" height="5"/>
    </svg>"""
    result = import_drawing(F.write(tmp_path, "bar.svg", svg))
    assert sorted(p.id for p in result.assembly.parts) == ["a", "b"]
    assert "1 page bar" in result.summary()
    # the same bar as wide as the parts only, not the page: a part
    short = import_drawing(F.write(tmp_path, "short.svg", svg.replace('x="0" y="45" width="100"',
                                                                       'x="10" y="45" width="40"')))
    assert sorted(p.id for p in short.assembly.parts) == ["a", "b", "bar"]


# Inkscape: a locked "Template" layer drawing the square the pieces fill, and its cut line,
# under a parts layer of two pieces; the locked layer would otherwise cross the pieces
SVG_LOCKED_TEMPLATE = """<svg xmlns="http://www.w3.org/2000/svg"
     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"
     width="100mm" height="100mm" viewBox="0 0 100 100">
  <g inkscape:groupmode="layer" id="layer1" inkscape:label="Template" {lock}>
    <rect id="frame" x="10" y="10" width="40" height="40" fill="none" stroke="black"/>
    <path id="cut" d="M 10 10 L 50 50" stroke="black"/>
    <path id="cut2" d="M 20 10 L 20 50" stroke="black"/>
  </g>
  <g inkscape:groupmode="layer" id="layer2" inkscape:label="Pieces">
    <path id="p1" d="M 10 10 L 50 10 L 50 50 Z"/>
    <path id="p2" d="M 10 10 L 50 50 L 10 50 Z"/>
  </g>
</svg>
"""


def test_a_locked_layer_drawn_over_the_parts_is_left_out_and_said_so(tmp_path):
    locked = F.write(tmp_path, "locked.svg",
                     SVG_LOCKED_TEMPLATE.format(lock='sodipodi:insensitive="true"'))
    result = import_drawing(locked)
    assert len(result.assembly.parts) == 2
    assert sum(F.area(p) for p in result.assembly.parts) == 1600
    assert "3 paths of a locked layer drawn over a part on layer 'Template'" in result.summary()
    # unlocked, the same template is read as geometry: its cut line splits a piece in two
    unlocked = F.write(tmp_path, "unlocked.svg", SVG_LOCKED_TEMPLATE.format(lock=""))
    assert len(import_drawing(unlocked).assembly.parts) == 4


def test_a_locked_layer_apart_from_the_others_stays():
    from rap.cad.arrangement.annotations import sort_out

    paths = [F.polygon([(0, 0), (10, 0), (10, 10), (0, 10)], "a", 0, "Locked"),
             F.polygon([(20, 0), (30, 0), (30, 10), (20, 10)], "b", 1, "Parts")]
    sorting = sort_out(paths, 0.01, locked=frozenset({"Locked"}))
    assert len(sorting.kept) == 2 and not sorting.left_out
