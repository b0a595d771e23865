"""Jigsaw puzzles with curved tabs (``puzzle``): a grid of pieces whose shared edges carry bumps.

``rows`` x ``cols`` pieces of a grid; every inner edge carries one curved tab, a bump that belongs
to one of its two pieces (drawn) and fills the other's matching socket exactly. A tab is the
quartic ``v = a (1 - (u / b)^2)^2`` (half-width ``b``, height ``a``) sampled at every integer ``u``
and rounded exactly (``Fraction``): a curve as a polyline on the integer grid, both pieces using
the same points. Tabs keep ``a <= b / 2``, so no polyline step is steeper than 1 (the quartic's
steepest slope is ``1.54 a / b``, and a rounded unit step rises by at most one): a tab never
undercuts, and a piece with no neighbour above or to its left can leave along (-1, 1).

Not interlocked: pieces leave along (-1, 1) anti-diagonal by anti-diagonal from the top-left
corner (``verify`` checks it exactly). Parts: rows x cols (6, 8, 9, 12 with the drawn sizes).
Cost: O(parts x tab width). Held out of training (``Family.training`` False).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["PUZZLE"]


def _count(o: dict) -> int:
    return o["rows"] * o["cols"]


def _problem(o: dict) -> tuple[str, str] | None:
    if o["rows"] * o["cols"] < 2:
        return ("cols", "a puzzle needs two pieces")
    return None


def _tab(a: int, b: int) -> list[tuple[int, int]]:
    """The bump's (u, v) points for u = -b..b (exact quartic, rounded to integers)."""
    return [(u, round(a * (1 - Fraction(u, b) ** 2) ** 2)) for u in range(-b, b + 1)]


def _edge(rng: np.random.Generator, length: int) -> tuple[int, list[tuple[int, int]]]:
    """(sign, (offset along the edge, height) points) of one tab on an edge of ``length``."""
    b = int(rng.integers(4, max(5, length // 3)))
    a = int(rng.integers(2, b // 2 + 1))
    centre = length // 2 + int(rng.integers(-(length // 2 - b - 3), length // 2 - b - 2))
    sign = 1 if rng.integers(2) else -1
    return sign, [(centre + u, sign * v) for u, v in _tab(a, b)]


def _puzzle(rng: np.random.Generator, o: dict) -> list:
    rows, cols = o["rows"], o["cols"]
    sx = int(rng.integers(20, 29))
    sy = int(rng.integers(20, 29))
    # horizontal edge above row r (r = 1..rows-1) at column c: points left -> right
    hor = {(r, c): [(c * sx + u, r * sy + v) for u, v in _edge(rng, sx)[1]]
           for r in range(1, rows) for c in range(cols)}
    # vertical edge right of column c (c = 1..cols-1) at row r: points bottom -> top
    ver = {(r, c): [(c * sx + v, r * sy + u) for u, v in _edge(rng, sy)[1]]
           for r in range(rows) for c in range(1, cols)}
    parts = []
    for r in range(rows):
        for c in range(cols):
            x0, x1, y0, y1 = c * sx, (c + 1) * sx, r * sy, (r + 1) * sy
            ring = [(x0, y0)] + (hor[r, c] if r > 0 else []) + [(x1, y0)]
            ring += (ver[r, c + 1] if c + 1 < cols else []) + [(x1, y1)]
            ring += (hor[r + 1, c][::-1] if r + 1 < rows else []) + [(x0, y1)]
            ring += ver[r, c][::-1] if c > 0 else []
            parts.append(make_part(f"p{r}_{c}", ring))
    return parts


PUZZLE = Family(
    "puzzle", "A jigsaw grid of pieces joined by curved tabs (quartic bumps as integer polylines).",
    (Option("rows", "Rows of pieces.", 1, 8, draw_low=2, draw_high=3),
     Option("cols", "Pieces per row.", 1, 8, draw_low=3, draw_high=4)),
    _puzzle, _count, ("rows", "cols"), _problem, training=False)
