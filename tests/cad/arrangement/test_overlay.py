"""rap.cad.arrangement.overlay: hand-placed loops overlapping by a hair share their boundary exactly."""

from __future__ import annotations

import pytest

from rap.cad.drawing import Problem
from rap.cad.loops import join_loops
from rap.cad.arrangement.overlay import overlay_parts
from rap.cad.snap import Grid

from tests.cad.fixtures import polygon


def loops(*paths, tol=0.1):
    return join_loops(list(paths), tol, "mm")


def test_a_thin_overlap_goes_to_the_earlier_piece_and_the_pieces_touch():
    a = polygon([(0, 0), (10, 0), (10, 10), (0, 10)], "a", 0)
    b = polygon([(9.96, 0), (20, 0), (20, 10), (9.96, 10)], "b", 1)  # 0.04 over a
    grid = Grid.parse("0.1")
    pa, pb = overlay_parts(loops(a, b), grid, "mm")
    assert (pa.id, pb.id) == ("0:a", "0:b")
    xs_a = {x for x, _ in pa.outer}
    xs_b = {x for x, _ in pb.outer}
    assert max(xs_a) == min(xs_b) == 100  # x = 10 mm on the 0.1 grid: a kept the overlap


def test_an_overlap_deeper_than_the_tolerance_is_refused_with_its_size():
    a = polygon([(0, 0), (10, 0), (10, 10), (0, 10)], "a", 0)
    b = polygon([(8, 0), (20, 0), (20, 10), (8, 10)], "b", 1)
    with pytest.raises(Problem, match=r"overlap by 20 mm\^2, 1.67 mm deep, more than the "
                                      r"tolerance 0\.1 mm"):
        overlay_parts(loops(a, b), Grid.parse("0.1"), "mm")


def test_holes_and_pegs_keep_their_nesting():
    plate = polygon([(0, 0), (30, 0), (30, 30), (0, 30)], "plate", 0)
    hole = polygon([(10, 10), (20, 10), (20, 20), (10, 20)], "hole", 1)
    peg = polygon([(12, 12), (18, 12), (18, 18), (12, 18)], "peg", 2)
    parts = overlay_parts(loops(plate, hole, peg), Grid.parse("1"), "mm")
    assert [(p.id, len(p.holes)) for p in parts] == [("0:plate", 1), ("0:peg", 0)]
