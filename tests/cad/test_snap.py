"""rap.cad.snap: the tolerance grid."""

from __future__ import annotations

from decimal import Decimal

import pytest

from rap.cad.snap import Grid
from rap.errors import InputError


@pytest.mark.parametrize("text,needle", [("1e-7", "finer"), ("0.0000015", "finer"),
                                         ("0", "positive"), ("-1", "positive"), ("abc", "number"),
                                         ("5000", "coarser")])
def test_bad_tolerances_are_refused_in_one_line(text, needle):
    with pytest.raises(InputError, match=needle) as e:
        Grid.parse(text)
    assert "\n" not in str(e.value)


def test_the_grid_is_exact():
    g = Grid.parse("0.0025")
    assert g.value(g.index(1.0)) == Decimal(1) and g.value(3) == Decimal("0.0075")
    assert Grid.parse(1e-6).step == Decimal("0.000001")
