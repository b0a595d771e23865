"""C- and L-shapes on a floor (``c-shapes``).

A floor plate carries ``columns`` columns side by side, ``gap`` apart (0: they touch). Each column
is one of (``kind``; ``mixed`` draws one per column):

* ``c-up``: a U-shaped part opening upward with an insert in its mouth (the insert may stand
  above the rim);
* ``c-side``: a C opening left or right with an insert flush with its open side, which slides in
  sideways (a touching neighbour closes that side until it is gone);
* ``l``: two L-shapes that complete a rectangle, the upper one hooked over the lower one's foot.

Clearances (gaps around the insert, or between the two Ls along their vertical contacts) are drawn
per column in 0..``max_clearance``; column sizes and wall thickness are drawn per column, so
aspect ratios vary.

Not interlocked by construction: each column lies in its own vertical slab above the floor with
nothing above it, so a whole column leaves upward; inside a column the insert (or the upper L)
leaves upward or sideways once the column stands alone. Parts: 1 + 2 x columns. Cost: O(parts).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["C_SHAPES"]

KINDS = ("c-up", "c-side", "l")


def _count(o: dict) -> int:
    return 1 + 2 * o["columns"]


def _column(rng: np.random.Generator, kind: str, x0: int, t: int, c: int, k: int) -> tuple[list, int]:
    """The two parts of a column starting at x0 on the floor (y = 0) and its width."""
    if kind == "c-up":
        lo = max(18, 2 * t + 2 * c + 6)
        w = int(rng.integers(lo, lo + 11))
        h = int(rng.integers(14, 27))
        x1 = x0 + w
        cup = [(x0, 0), (x1, 0), (x1, h), (x1 - t, h), (x1 - t, t), (x0 + t, t), (x0 + t, h), (x0, h)]
        stand = int(rng.integers(0, 7))
        ins = [(x0 + t + c, t), (x1 - t - c, t), (x1 - t - c, h + stand), (x0 + t + c, h + stand)]
        return [make_part(f"c{k}", cup), make_part(f"in{k}", ins)], w
    if kind == "c-side":
        lo = max(16, t + c + 8)
        w = int(rng.integers(lo, lo + 11))
        lo = max(16, 2 * t + c + 6)
        h = int(rng.integers(lo, lo + 13))
        x1 = x0 + w
        cee = [(x0, 0), (x1, 0), (x1, t), (x0 + t, t), (x0 + t, h - t), (x1, h - t), (x1, h), (x0, h)]
        ins = [(x0 + t + c, t), (x1, t), (x1, h - t - c), (x0 + t + c, h - t - c)]
        if rng.random() < 0.5:  # open to the left: mirror about the column's centre
            cee = [(2 * x0 + w - x, y) for x, y in cee]
            ins = [(2 * x0 + w - x, y) for x, y in ins]
        return [make_part(f"c{k}", cee), make_part(f"in{k}", ins)], w
    w = int(rng.integers(20 + 2 * c, 31 + 2 * c))
    h = int(rng.integers(16, 29))
    x1 = x0 + w
    foot = int(rng.integers(4, h // 2))  # height of the lower L's foot
    post = int(rng.integers(4, w // 3 + 1))  # width of the lower L's post
    reach = int(rng.integers(post + 5, w - 4 - c))  # the foot's length
    lower = [(x0, 0), (x0 + reach, 0), (x0 + reach, foot), (x0 + post, foot), (x0 + post, h), (x0, h)]
    upper = [(x0 + reach + c, 0), (x1, 0), (x1, h), (x0 + post + c, h), (x0 + post + c, foot),
             (x0 + reach + c, foot)]
    return [make_part(f"la{k}", lower), make_part(f"lb{k}", upper)], w


def _shapes(rng: np.random.Generator, o: dict) -> list:
    edge = int(rng.integers(2, 7))
    x = edge
    parts = []
    for k in range(o["columns"]):
        kind = o["kind"] if o["kind"] != "mixed" else KINDS[int(rng.integers(len(KINDS)))]
        t = int(rng.integers(o["wall"], o["wall"] + 2))
        c = int(rng.integers(0, o["max_clearance"] + 1))
        col, w = _column(rng, kind, x, t, c, k)
        parts += col
        x += w + o["gap"]
    width = x - o["gap"] + edge
    floor_h = int(rng.integers(5, 9))
    return [make_part("floor", [(0, -floor_h), (width, -floor_h), (width, 0), (0, 0)]), *parts]


C_SHAPES = Family(
    "c-shapes", "C-shapes with inserts (opening up or sideways) and pairs of hooked L-shapes.",
    (Option("columns", "Columns on the floor (each a C with its insert or two Ls).", 1, 10,
            draw_low=2, draw_high=5),
     Option("kind", "Column kind (mixed: drawn per column).", choices=(*KINDS, "mixed")),
     Option("max_clearance", "Each column's clearance is drawn in 0..this.", 0, 4,
            draw_low=1, draw_high=3),
     Option("wall", "Wall thickness of the Cs (drawn in wall..wall+1).", 2, 8, draw_low=3,
            draw_high=5),
     Option("gap", "Space between neighbouring columns (0: they touch).", 0, 8, draw_low=0,
            draw_high=4)),
    _shapes, _count, ("columns",))
