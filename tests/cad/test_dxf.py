"""DXF import (drawings written with ezdxf in the tests): exact vertices, touching stays touching.

"Touching" is checked exactly: the assembly is validated (no two interiors overlap), and the
parts' exact areas add up to the area of the region they tile, so no gap is left either; the two
sides of a shared curve carry the same vertices.
"""

from __future__ import annotations

import math
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import pytest

from rap.assembly import signed_area2
from rap.cad import DrawingError, ImportOptions, import_drawing
from rap.geometry.ndbg import build_ndbg, is_feasible_operation
from tests.cad import fixtures as F

F100 = Fraction(1, 100)


def parts(path, **options):
    return {p.id: p for p in import_drawing(path, ImportOptions(**options)).assembly.parts}


def on_grid(part, step=F100):
    return all((v / step).denominator == 1 for ring in part.rings() for pt in ring for v in pt)


def test_bulged_polylines_share_the_arc_exactly(tmp_path):
    p = parts(F.dxf_bulged_pair(tmp_path))
    a, b = p["A"], p["B"]
    shared = set(a.outer) & set(b.outer)
    arc = [v for v in a.outer if v[0] > 10]
    assert len(arc) >= 8 and set(arc) <= shared  # every vertex of A's bulge is one of B's
    assert a.area() + b.area() == 200  # no gap (and validation: no overlap)
    assert a.area() > 100  # the bulge goes into B
    # the arc through (10, 0) and (10, 10) with bulge 0.3: centre and radius from the bulge
    sagitta = Decimal("0.3") * 5
    r = (25 + sagitta ** 2) / (2 * sagitta)
    cx = 10 + float(sagitta) - float(r)
    for x, y in arc:
        assert abs(math.hypot(float(x) - cx, float(y) - 5) - float(r)) <= 0.02
    assert on_grid(a) and on_grid(b)


def test_loose_lines_and_arcs_join_into_loops_sharing_the_arc(tmp_path):
    p = parts(F.dxf_arc_chains(tmp_path))
    a, b = p["A"], p["B"]
    assert a.area() + b.area() == 200
    assert sorted(v for v in a.outer if 10 < v[0] < 20) == \
        sorted(v for v in b.outer if 10 < v[0] < 20)
    ndbg = build_ndbg(import_drawing(F.dxf_arc_chains(tmp_path)).assembly)
    assert not is_feasible_operation(ndbg, ["A"], ["B"], (1, 0))  # A's half disc sits in B
    assert is_feasible_operation(ndbg, ["A"], ["B"], (-1, 0))


def test_a_circle_split_differently_on_each_side_keeps_its_contacts(tmp_path):
    """The CIRCLE hole is split at 0 and 180 degrees, the half discs at 90 and 270: the
    T-junctions on the curve are inserted, and the halves fill the hole exactly."""
    p = parts(F.dxf_split_hole(tmp_path))
    plate, left, right = p["plate"], p["left"], p["right"]
    (hole,) = plate.holes
    assert left.area() + right.area() == abs(signed_area2(hole)) / 2
    assert plate.area() + left.area() + right.area() == 400
    # every vertex of the halves is on the circle (the diameter has none inside): the hole has
    # the vertices of both, its own split points (0 and 180 degrees) and theirs (90, 270)
    assert set(hole) == set(left.outer) | set(right.outer)
    assert {(10, 7), (10, 13), (13, 10), (7, 10)} <= set(hole)


def test_a_straight_edge_gets_the_t_junction_vertices_of_its_neighbours(tmp_path):
    p = parts(F.dxf_t_junction(tmp_path))
    a = p["A"]
    assert (11, 3) in a.outer and (12, 6) in a.outer
    assert sum(q.area() for q in p.values()) == 20 * 9


def test_a_spline_drawn_from_both_sides_is_flattened_once(tmp_path):
    p = parts(F.dxf_spline_pair(tmp_path))
    a, b = p["A"], p["B"]
    curve_a = [v for v in a.outer if v not in {(0, 0), (0, 10)}]
    curve_b = [v for v in b.outer if v not in {(20, 0), (20, 10)}]
    assert sorted(curve_a) == sorted(curve_b) and len(curve_a) > 10
    assert a.area() + b.area() == 200


def test_loops_inside_loops_are_holes_and_a_part_in_a_hole_is_a_part(tmp_path):
    for mode in ("loop", "layer"):
        p = parts(F.dxf_holes(tmp_path), parts=mode)
        assert sorted(p) == ["peg", "plate"]
        plate, peg = p["plate"], p["peg"]
        assert len(plate.holes) == 2
        square = [h for h in plate.holes if len(h) == 4][0]
        assert set(square) == set(peg.outer) == {(20, 10), (25, 10), (25, 15), (20, 15)}
        assert peg.area() == 25
        circle = [h for h in plate.holes if len(h) > 4][0]
        assert plate.area() == 600 - 25 - abs(signed_area2(circle)) / 2


@pytest.mark.parametrize("units,side,out,expected", [
    (F.MM, 1, "mm", 1), (F.INCH, 1, "mm", Fraction("25.4")), (F.INCH, 1, "in", 1),
    (F.MM, 25, "cm", Fraction(5, 2)), (F.UNITLESS, 3, "mm", 3)])
def test_insunits_convert_to_the_output_unit(tmp_path, units, side, out, expected):
    path = F.dxf_square(tmp_path, units, side)
    (part,) = parts(path, units=out).values()
    assert set(part.outer) == {(0, 0), (expected, 0), (expected, expected), (0, expected)}


def test_an_ellipse_and_block_references(tmp_path):
    result = import_drawing(F.dxf_ellipse_and_block(tmp_path))
    p = {q.id: q for q in result.assembly.parts}
    assert p["E"].area() == pytest.approx(math.pi * 4 * 2, rel=0.01)
    bricks = sorted((q for q in p.values() if q.id.startswith("K:")), key=lambda q: q.outer[0])
    assert [set(q.outer) for q in bricks] == [{(10, 0), (12, 0), (12, 1), (10, 1)},
                                              {(12, 0), (14, 0), (14, 1), (12, 1)}]


def test_gaps_up_to_the_tolerance_are_closed_and_counted(tmp_path):
    result = import_drawing(F.dxf_small_gap(tmp_path, 0.004))
    assert result.gaps_closed == 1
    (part,) = result.assembly.parts
    assert set(part.outer) == {(0, 0), (10, 0), (0, 10)}
    assert "1 gaps closed" in result.summary()
    with pytest.raises(DrawingError, match=r"open loop.* is 0\.02 mm"):
        import_drawing(F.dxf_small_gap(tmp_path, 0.02))
    # a coarser tolerance closes it
    assert import_drawing(F.dxf_small_gap(tmp_path, 0.02),
                          ImportOptions(tolerance="0.05")).gaps_closed == 1


def test_the_tolerance_is_the_grid(tmp_path):
    path = F.dxf_bulged_pair(tmp_path)
    coarse = parts(path, tolerance="0.5")
    assert all(on_grid(q, Fraction(1, 2)) for q in coarse.values())
    fine = parts(path, tolerance="0.001")
    assert len(fine["A"].outer) > len(coarse["A"].outer)
    assert coarse["A"].area() + coarse["B"].area() == 200


def test_seven_parts_with_arcs_import_and_validate(tmp_path):
    result = import_drawing(F.dxf_seven(tmp_path))
    assert [p.id for p in result.assembly.parts] == ["tray", "b1", "b2", "b3", "cap", "d1", "d2"]
    p = {q.id: q for q in result.assembly.parts}
    assert p["b1"].area() + p["b2"].area() + p["b3"].area() == 300


def test_the_benchmark_grid_tiles_its_square_exactly(tmp_path):
    """benchmarks/cad_import.py's drawing, 3 x 3: every interior edge an arc drawn from both
    sides; the nine cells cover the 30 x 30 square with no gap and no overlap."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "cad_import", Path(__file__).resolve().parents[2] / "benchmarks" / "cad_import.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    cells = parts(bench.write_grid(tmp_path / "grid.dxf", 3))
    assert len(cells) == 9 and sum(c.area() for c in cells.values()) == 900
    middle = cells["c1_1"]
    assert middle.area() == 100  # it gains on its right and top what it loses left and below
    for other in ("c0_1", "c2_1", "c1_0", "c1_2"):
        assert len(set(middle.outer) & set(cells[other].outer)) > 8


def test_the_import_is_deterministic(tmp_path):
    a = import_drawing(F.dxf_arc_chains(tmp_path)).assembly
    b = import_drawing(F.dxf_arc_chains(tmp_path)).assembly
    assert a == b and a.geometry_hash == b.geometry_hash


def test_the_label_driver_records_a_drawings_geometry(tmp_path):
    """rap.dataset.write_geometry keeps the imported assembly as JSON that reads back exactly."""
    from rap.dataset import GEOMETRY_DIR, write_geometry
    from rap.io import load_assembly

    asm = load_assembly(F.dxf_split_hole(tmp_path))
    assert write_geometry(tmp_path / "ds", [asm]) == 1
    back = load_assembly(tmp_path / "ds" / GEOMETRY_DIR / f"{asm.name}.json")
    assert back.geometry_hash == asm.geometry_hash and back == asm
