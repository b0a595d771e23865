"""Where the cup holds a part and where parts wait: named tiny parts, exact coordinates."""

from __future__ import annotations

from fractions import Fraction

import pytest

from rap.assembly import Assembly, Part
from rap.robot.cell import Cell
from rap.robot.frames import cell_frame
from rap.robot.grasp import GraspError, _depth_inside, grasp_point, tray_slots


def part(pid, pts):
    return Part(pid, tuple((Fraction(x), Fraction(y)) for x, y in pts))


BASE = part("base", [(0, -10), (60, -10), (60, 0), (0, 0)])
L_SHAPE = part("ell", [(0, 0), (30, 0), (30, 10), (10, 10), (10, 30), (0, 30)])  # centroid outside
WEDGE = part("wedge", [(40, 0), (60, 0), (50, 20)])  # no flat top


def test_an_l_shape_is_held_inside_it_when_its_centroid_is_not():
    asm = Assembly("l", (BASE, L_SHAPE))
    frame = cell_frame(Cell(), asm, None)  # horizontal: no gravity
    g = grasp_point(asm, "ell", frame, Cell())
    rings = [L_SHAPE.float_outer()]
    assert _depth_inside(g.point, rings) >= Cell().gripper.cup_diameter_m / 2 / frame.scale_m
    assert g.depth_m == Cell().assembly.thickness_m


def test_a_vertical_part_is_held_on_its_highest_flat_top_and_a_wedge_is_refused():
    asm = Assembly("w", (BASE, L_SHAPE, WEDGE))
    frame = cell_frame(Cell(), asm, (0.0, -1.0))
    g = grasp_point(asm, "ell", frame, Cell())
    assert g.point == (5.0, 30.0) and g.height_m == pytest.approx(30 * frame.scale_m)
    with pytest.raises(GraspError, match="part wedge: no flat top face"):
        grasp_point(asm, "wedge", frame, Cell())


def test_the_tray_gives_every_part_its_own_slot_a_footprint_apart():
    asm = Assembly("w", (BASE, L_SHAPE, WEDGE))
    frame = cell_frame(Cell(), asm, None)
    slots = tray_slots(["ell", "wedge"], asm, frame, Cell())
    (x0, y0), (x1, y1) = slots["ell"], slots["wedge"]
    assert (x0, y0) == Cell().tray.origin_m and y1 == y0
    assert x1 - x0 >= 30 * frame.scale_m  # the larger part's box fits between them
