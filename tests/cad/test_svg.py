"""SVG import (fixtures written by hand): units, transforms, ids, holes, touching stays touching."""

from __future__ import annotations

from fractions import Fraction

import pytest

from rap.cad import DrawingError, ImportOptions, import_drawing
from tests.cad import fixtures as F

IN = Fraction("25.4")


def parts(path, **options):
    return {p.id: p for p in import_drawing(path, ImportOptions(**options)).assembly.parts}


def test_two_paths_sharing_an_arc_touch_exactly(tmp_path):
    p = parts(F.write(tmp_path, "touch.svg", F.SVG_TOUCHING_ARC))
    a, b = p["a"], p["b"]
    assert a.area() + b.area() == 200  # validated (no overlap) and no gap
    arc_a = sorted(v for v in a.outer if v[0] > 10)
    arc_b = sorted(v for v in b.outer if 10 < v[0] < 20)
    assert arc_a == arc_b and len(arc_a) > 8
    # y is up: the drawing's top edge y = 0 stays at y = 0, the rest goes below it
    assert max(y for _, y in a.outer) == 0 and min(y for _, y in a.outer) == -10
    assert Fraction(1498, 100) <= max(x for x, _ in a.outer) <= 15  # the apex, within 0.02


def test_physical_units_transforms_and_subpath_holes(tmp_path):
    result = import_drawing(F.write(tmp_path, "inch.svg", F.SVG_INCH_TRANSFORMS))
    assert "2in" in result.unit_note
    p = {q.id: q for q in result.assembly.parts}
    assert set(p) == {"sq", "disc", "ring"}
    inch = IN / 100  # 100 user units per inch
    assert set(p["sq"].outer) == {(100 * inch, 0), (150 * inch, 0), (150 * inch, -50 * inch),
                                  (100 * inch, -50 * inch)}
    ring = p["ring"]
    assert set(ring.outer) == {(150 * inch, -60 * inch), (190 * inch, -60 * inch),
                               (190 * inch, -100 * inch), (150 * inch, -100 * inch)}
    assert len(ring.holes) == 1 and set(ring.holes[0]) == {
        (160 * inch, -70 * inch), (180 * inch, -70 * inch), (180 * inch, -90 * inch),
        (160 * inch, -90 * inch)}
    assert float(p["disc"].area()) == pytest.approx(3.14159 * (25 * float(inch)) ** 2, rel=0.01)


def test_output_in_inches(tmp_path):
    p = parts(F.write(tmp_path, "inch.svg", F.SVG_INCH_TRANSFORMS), units="in")
    assert set(p["sq"].outer) == {(1, 0), (Fraction(3, 2), 0), (Fraction(3, 2), Fraction(-1, 2)),
                                  (1, Fraction(-1, 2))}


def test_an_svg_without_physical_units_reads_css_pixels_or_the_scale(tmp_path):
    path = F.write(tmp_path, "plain.svg", F.SVG_UNITLESS)
    # width 200 (px) over a 100-unit viewBox: 2 px per user unit, a px is 25.4/96 mm
    result = import_drawing(path)
    assert "CSS px" in result.unit_note and "--scale" in result.unit_note
    (part,) = result.assembly.parts
    assert float(max(x for x, _ in part.outer)) == pytest.approx(20 * 25.4 / 96, abs=0.01)
    # --scale is output units per SVG user unit: the viewBox's mapping (2 px each) is undone
    (part,) = parts(path, scale=2.0).values()
    assert set(part.outer) == {(0, 0), (20, 0), (20, -10), (0, -10)}


def test_groups_are_layers_and_open_polylines_join(tmp_path):
    path = F.write(tmp_path, "layers.svg", F.SVG_LAYERS)
    by_layer = parts(path, parts="layer")
    assert set(by_layer) == {"frame", "block"}
    assert len(by_layer["frame"].holes) == 1
    assert set(by_layer["block"].outer) == {(10, 0), (20, 0), (20, -10), (10, -10)}
    by_loop = parts(path)
    assert len(by_loop) == 2 and sum(len(q.holes) for q in by_loop.values()) == 1


def test_bad_svgs_are_one_line(tmp_path):
    selfx = F.write(tmp_path, "zig.svg", '<svg xmlns="http://www.w3.org/2000/svg" width="10mm" '
                    'height="10mm" viewBox="0 0 10 10"><path id="zig" d="M0 0 L10 10 L10 0 '
                    'L0 5 Z"/></svg>')
    with pytest.raises(DrawingError, match=r"<path id='zig'>: self-intersection near") as e:
        import_drawing(selfx)
    assert "\n" not in str(e.value)
    broken = F.write(tmp_path, "broken.svg", '<svg width="10mm"')
    with pytest.raises(DrawingError, match="not a readable SVG file"):
        import_drawing(broken)
