"""Step reasons (rap.plan.report.reasons) on small assemblies whose limiting geometry is known by hand."""

from __future__ import annotations

import math

import pytest

from rap.model.data.descriptors import DescriptorContext
from rap.operation import Operation
from rap.plan.report.reasons import format_length, step_quantities, step_reason

from tests.plan.cases import memory


def _block_and_peg(peg_x0: int, peg_x1: int) -> dict:
    """A block with a slot x in [8, 12], y in [4, 24] (20 deep), and a peg x in [peg_x0, peg_x1],
    y in [4, 30], standing on the slot's floor; in millimetres."""
    return {"name": "peg", "units": "mm", "parts": [
        {"id": "block", "polygon": [[0, 0], [20, 0], [20, 24], [12, 24], [12, 4], [8, 4], [8, 24],
                                    [0, 24]]},
        {"id": "peg", "polygon": [[peg_x0, 4], [peg_x1, 4], [peg_x1, 30], [peg_x0, 30]]}]}


DOWN = Operation(frozenset({"peg"}), frozenset({"block"}), (0.0, -1.0))


def test_a_centred_peg_is_limited_by_its_direction_range_and_its_side_clearance():
    asm = memory(_block_and_peg(9, 11))  # 1 mm each side, 20 mm deep
    ctx = DescriptorContext(asm)
    qs = {q.name: q for q in step_quantities(ctx, DOWN, asm.units)}
    half = math.degrees(math.atan(1 / 20))  # the peg drifts 1 mm over 20 mm at the range's ends
    assert qs["direction range"].value == pytest.approx(half, rel=1e-6)
    assert qs["clearance"].value == pytest.approx(1.0, rel=1e-6)
    assert qs["depth"].value == pytest.approx(20.0, rel=1e-6)
    assert "sliding contact" not in qs  # its sides touch nothing
    assert step_reason(ctx, DOWN, asm.units) == (
        f"direction range {2 * half:.2g}° wide (margin {half:.2g}°); clearance 1 mm")


def test_a_peg_that_fits_its_slot_has_one_direction_and_slides_along_both_walls():
    asm = memory(_block_and_peg(8, 12))
    reason = step_reason(DescriptorContext(asm), DOWN, asm.units)
    assert reason == "a single insertion direction; sliding contact 40 mm"


def test_a_part_set_on_a_plate_is_limited_only_by_its_half_plane():
    asm = memory({"name": "plate", "parts": [
        {"id": "plate", "polygon": [[0, 0], [30, 0], [30, 5], [0, 5]]},
        {"id": "box", "polygon": [[10, 5], [20, 5], [20, 15], [10, 15]]}]})
    op = Operation(frozenset({"box"}), frozenset({"plate"}), (0.0, -1.0))
    qs = step_quantities(DescriptorContext(asm), op, asm.units)
    assert [q.name for q in qs] == ["direction range"]
    assert step_reason(DescriptorContext(asm), op) == "direction range 180° wide (margin 90°)"


def test_the_tightest_quantity_comes_first():
    wide = step_quantities(DescriptorContext(memory(_block_and_peg(9, 11))), DOWN)
    assert [q.tightness for q in wide] == sorted((q.tightness for q in wide), reverse=True)


def test_an_infeasible_operation_is_refused():
    asm = memory(_block_and_peg(9, 11))
    sideways = Operation(frozenset({"peg"}), frozenset({"block"}), (1.0, 0.0))
    with pytest.raises(ValueError):
        step_reason(DescriptorContext(asm), sideways)


@pytest.mark.parametrize("value,units,text", [(0.5, "mm", "0.5 mm"), (1.0, "mm", "1 mm"),
                                              (12.34, "in", "12 in"), (0.5, "unit", "0.5 units"),
                                              (2.5e-5, "m", "0.000025 m")])
def test_lengths_read_with_their_units(value, units, text):
    assert format_length(value, units) == text
