"""rap.cad.arrangement.faces on plain drawn paths: faces of cut lines, cut-outs by nesting, snap rounding."""

from __future__ import annotations

from rap.assembly import signed_area2
from rap.cad.drawing import DrawnPath
from rap.cad.arrangement.faces import face_parts
from rap.cad.snap import Grid
from rap.geometry.validation import ring_is_simple

from tests.cad.fixtures import polygon, src


def line(points, name, order=0):
    return DrawnPath([list(points)], src(name, order, "0"), False)


def test_a_border_and_cuts_make_faces_and_a_cut_out_stays_a_hole():
    border = polygon([(0, 0), (20, 0), (20, 10), (0, 10)], "border")
    cut = line([(10, 0), (10, 10)], "cut", 1)
    hole = polygon([(2, 2), (4, 2), (4, 4), (2, 4)], "hole", 2)
    peg = polygon([(2.5, 2.5), (3.5, 2.5), (3.5, 3.5), (2.5, 3.5)], "peg", 3)
    parts, gaps = face_parts([border, cut, hole, peg], Grid.parse("0.5"))
    assert gaps == 0
    by_area = sorted((abs(signed_area2(p.outer)) / 2, len(p.holes)) for p in parts)
    # in grid cells of 0.5: the peg (2x2), the left half with its hole (20x20), the right half
    assert by_area == [(4, 0), (400, 0), (400, 1)]


def test_an_end_short_of_a_line_by_less_than_the_tolerance_meets_it():
    border = polygon([(0, 0), (20, 0), (20, 10), (0, 10)], "border")
    cut = line([(10, 0.004), (10, 9.997)], "cut", 1)  # short of both sides by a hair
    parts, gaps = face_parts([border, cut], Grid.parse("0.01"))
    assert gaps == 2 and len(parts) == 2
    assert sorted(abs(signed_area2(p.outer)) for p in parts) == [2 * 1000 * 1000] * 2


def test_snap_rounding_keeps_a_thin_spike_simple():
    # a spike thinner than the grid: plain rounding folds it onto itself, snap rounding does not
    spike = polygon([(0, 0), (10, 0), (10, 1), (5, 1), (5, 5), (5.004, 1), (0, 1)], "spike")
    parts, _ = face_parts([spike], Grid.parse("0.01"))
    for p in parts:
        assert ring_is_simple(p.outer) and signed_area2(p.outer) > 0
