"""rap.cad.snap: the tolerance grid."""

from __future__ import annotations

from decimal import Decimal

import pytest

from rap.cad.snap import Grid
from rap.errors import ParameterError


FINER = "finer than the coordinate grid 1e-6 of assembly files (at most 6 digits after the point)"


@pytest.mark.parametrize("text,message", [
    ("1e-7", f"tolerance 1e-7: {FINER}"), ("0.0000015", f"tolerance 0.0000015: {FINER}"),
    ("0", "tolerance 0: must be a positive number"),
    ("-1", "tolerance -1: must be a positive number"),
    ("abc", "tolerance 'abc': not a number"), ("5000", "tolerance 5000: coarser than 1000 units")])
def test_bad_tolerances_are_refused_in_one_line(text, message):
    """One line naming the parameter (``rap-farm import`` shows ``--tolerance``)."""
    with pytest.raises(ParameterError) as e:
        Grid.parse(text)
    assert e.value.parameter == "tolerance" and str(e.value) == message


def test_the_grid_is_exact():
    g = Grid.parse("0.0025")
    assert g.value(g.index(1.0)) == Decimal(1) and g.value(3) == Decimal("0.0075")
    assert Grid.parse(1e-6).step == Decimal("0.000001")
