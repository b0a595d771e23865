"""Assembly generators for scaling experiments (integer coordinates, always valid).

* ``grid(k, size=10)``: k x k axis-aligned squares of side ``size``.
* ``random_tiling(n_parts, rng)``: an r x c grid (r c = n_parts, r the largest divisor of n_parts
  not above its square root) of cells of side 12 whose vertices are jittered by random integers
  in [-3, 3]. Shared vertices stay shared, so neighbouring quads touch along whole edges; a
  jitter of at most a quarter of the spacing keeps every quad convex and simple (each corner
  moves less than the distance at which an edge could fold), and the result is validated exactly.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from rap.assembly import Assembly, Part

__all__ = ["grid", "random_tiling"]


def _ring(pts) -> tuple:
    return tuple((Fraction(x), Fraction(y)) for x, y in pts)


def grid(k: int, size: int = 10, name: str | None = None) -> Assembly:
    """k x k unit squares scaled by ``size``; ids ``r{row}c{col}`` (row 0 at the bottom)."""
    if k < 1 or size < 1:
        raise ValueError("k and size must be positive")
    parts = []
    for r in range(k):
        for c in range(k):
            x, y = c * size, r * size
            parts.append(Part(f"r{r}c{c}", _ring([(x, y), (x + size, y), (x + size, y + size),
                                                   (x, y + size)])))
    return Assembly(name or f"grid{k}x{k}", tuple(parts))


def _shape(n: int) -> tuple[int, int]:
    r = max(d for d in range(1, math.isqrt(n) + 1) if n % d == 0)
    return r, n // r


def random_tiling(n_parts: int, rng: np.random.Generator, spacing: int = 12,
                  jitter: int = 3, name: str | None = None) -> Assembly:
    """A jittered r x c grid of convex quads with exactly ``n_parts`` parts (validated)."""
    from rap.geometry.validation import validate_assembly

    if n_parts < 1:
        raise ValueError("n_parts must be positive")
    if not 0 <= 4 * jitter <= spacing:
        raise ValueError("jitter must be at most a quarter of the spacing")
    rows, cols = _shape(n_parts)
    jx = rng.integers(-jitter, jitter + 1, size=(rows + 1, cols + 1))
    jy = rng.integers(-jitter, jitter + 1, size=(rows + 1, cols + 1))

    def v(r, c):
        return (c * spacing + int(jx[r, c]), r * spacing + int(jy[r, c]))

    parts = [Part(f"q{r}_{c}", _ring([v(r, c), v(r, c + 1), v(r + 1, c + 1), v(r + 1, c)]))
             for r in range(rows) for c in range(cols)]
    asm = Assembly(name or f"tiling{n_parts}", tuple(parts))
    validate_assembly(asm)
    return asm
