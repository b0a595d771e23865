"""Floats onto an exact grid: the chordal tolerance is also the grid step of the imported drawing.

``Grid.parse(tolerance)`` reads the tolerance as a decimal (text, ``Decimal`` or a float's
shortest repr) and refuses, in one line, anything that is not positive, finer than 10^-6 (the
finest grid of ``rap.assembly.LIMITS``: at most 6 digits after the point) or coarser than
1,000 units. ``grid.index(x)`` is the nearest grid index of a float (``round(x / step)``; a
coordinate past ``LIMITS.max_abs_coordinate`` is refused before it is converted), and
``grid.value(k)`` is the exact ``Decimal`` ``k * step``, which has at most 6 digits after the point
and reads back exactly through ``rap.assembly``. Exact geometry downstream works on the integer
indices: every coordinate of an imported drawing is ``index * step``, so orientation and
containment tests on indices are the exact tests on the coordinates.

Snapping moves a point by at most ``step * sqrt(2) / 2``. Two floats that differ by rounding
noise can land on neighbouring grid points; the importer never relies on that not happening: it
merges endpoints within the tolerance before it snaps them (``rap.cad.edges``), so a shared
vertex is snapped once. No third-party imports; O(1) per coordinate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from fractions import Fraction

from rap.assembly import LIMITS
from rap.errors import ParameterError

__all__ = ["Grid", "TOLERANCE_BOUNDS"]

#: finest and coarsest tolerance accepted (units of the output)
TOLERANCE_BOUNDS = (Decimal(1).scaleb(-LIMITS.max_decimal_places), Decimal(1000))


@dataclass(frozen=True)
class Grid:
    """A square grid of exact step ``step`` (a positive ``Decimal`` of at most 6 decimals)."""

    step: Decimal

    @classmethod
    def parse(cls, tolerance: str | Decimal | float | int) -> "Grid":
        """The grid of a tolerance; ``ParameterError`` (parameter ``tolerance``) for a bad one."""
        text = repr(tolerance) if isinstance(tolerance, float) else str(tolerance)
        try:
            step = Decimal(text.strip())
        except (InvalidOperation, ValueError):
            raise ParameterError("tolerance", text, "not a number") from None
        lo, hi = TOLERANCE_BOUNDS
        if not step.is_finite() or step <= 0:
            raise ParameterError("tolerance", text, "must be a positive number", quote=False)
        if step < lo or step.normalize().as_tuple().exponent < -LIMITS.max_decimal_places:
            raise ParameterError("tolerance", text, f"finer than the coordinate grid 1e-6 of "
                                 f"assembly files (at most {LIMITS.max_decimal_places} digits "
                                 f"after the point)", quote=False)
        if step > hi:
            raise ParameterError("tolerance", text, f"coarser than {hi} units", quote=False)
        return cls(step.normalize())

    @property
    def step_float(self) -> float:
        return float(self.step)

    def index(self, x: float) -> int:
        """The nearest grid index of ``x`` (``ValueError`` for a non-finite or out-of-range x)."""
        if not math.isfinite(x) or abs(x) > LIMITS.max_abs_coordinate:
            raise ValueError(x)
        return round(x / self.step_float)

    def value(self, k: int) -> Decimal:
        """The exact coordinate of index ``k``."""
        return (self.step * k).normalize() if k else Decimal(0)

    def ring(self, coords) -> list[tuple[int, int]]:
        """The grid indices of a closed ring of float coordinates (the first point repeated
        last, as shapely gives rings), repeats dropped; for coordinates already on the grid
        (snap-rounded) this is exact."""
        ring: list[tuple[int, int]] = []
        for x, y in list(coords)[:-1]:
            n = (self.index(x), self.index(y))
            if not ring or ring[-1] != n:
                ring.append(n)
        while len(ring) > 1 and ring[-1] == ring[0]:
            ring.pop()
        return ring

    def fraction(self, k: int) -> Fraction:
        return Fraction(self.step) * k
