"""Jigsaw-like pieces with knobs that come apart by translation (``knobs``).

A ``rows`` x ``cols`` grid of rectangular cells (cell sizes drawn per assembly, so aspect ratios
vary); each internal edge carries, with probability ``knob_pct`` %, a knob of the chosen ``shape``
(``mixed``: drawn per edge) protruding into either neighbour, in a socket with ``clearance``:

* ``trapezoid``: narrowing toward its tip (a self-guiding wedge);
* ``rect``: a rectangular tab (tight: one direction only);
* ``round``: a bevelled cap (a polygonal half-disc);
* ``v``: a triangular tooth;
* ``step``: a wide base under a narrower tip.

No dovetails: every knob's half-width is non-increasing from base to tip, so a knob leaves its
socket along the edge normal. Knobs sit within the middle half of an edge and are at most a
quarter of the cell deep, so knobs of different edges never meet.

Not interlocked by construction: the top row leaves upward as one subassembly (each knob between
rows leaves along its axis), and a row comes apart from its right end rightward. Parts:
rows x cols; a cell has 4 corners plus up to 8 vertices per knob, and at most 3 knobs. Cost: O(parts).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, make_part, shared_edge

__all__ = ["KNOBS", "knob_profile", "SHAPES"]

SHAPES = ("trapezoid", "rect", "round", "v", "step")


def _count(o: dict) -> int:
    return o["rows"] * o["cols"]


def knob_profile(shape: str, half: int, depth: int) -> list[tuple[int, int]]:
    """Half-profile of a knob of half-width ``half`` (>= 3) and ``depth`` (>= 3)."""
    if shape == "trapezoid":
        return [(half, 0), (half - max(1, half // 2), depth)]
    if shape == "rect":
        return [(half, 0), (half, depth)]
    if shape == "round":
        return [(half, 0), (half, depth - 2), (half - 2, depth)]
    if shape == "v":
        return [(half, 0), (0, depth)]
    if shape == "step":
        return [(half, 0), (half, depth // 2), (half - 2, depth // 2), (half - 2, depth)]
    raise ValueError(f"unknown knob shape {shape!r}")


def _knobs(rng: np.random.Generator, o: dict) -> list:
    rows, cols, c = o["rows"], o["cols"], o["clearance"]
    sx, sy = int(rng.integers(24, 35)), int(rng.integers(24, 35))

    keyed = np.zeros((cols, rows), dtype=int)  # knobs per cell (at most 3: fewer vertices)

    def knob(along: int, across: int, cells):
        """(profile, offset from the edge's middle) fitting in the middle half of the edge."""
        if rng.random() * 100 >= o["knob_pct"] or any(keyed[q] >= 3 for q in cells):
            return None
        for q in cells:
            keyed[q] += 1
        shape = o["shape"] if o["shape"] != "mixed" else SHAPES[int(rng.integers(len(SHAPES)))]
        room_u, room_v = along // 4 - 1 - c, across // 4 - 1 - c
        half = int(rng.integers(3, max(3, room_u) + 1))
        depth = int(rng.integers(3, max(3, room_v) + 1))
        jitter = max(0, room_u - half)
        return knob_profile(shape, half, depth), int(rng.integers(-jitter, jitter + 1))

    def side():
        return 1 if rng.random() < 0.5 else -1

    # horizontal edges between row j (below) and j + 1, left to right: the upper cell is on the left
    horiz, vert = {}, {}
    for j in range(rows - 1):
        for i in range(cols):
            a, b = (i * sx, (j + 1) * sy), ((i + 1) * sx, (j + 1) * sy)
            k = knob(sx, sy, [(i, j), (i, j + 1)])
            horiz[i, j] = shared_edge(a, b, k and k[0], k and sx // 2 + k[1], side(), c)
    # vertical edges between column i (left) and i + 1, bottom to top: the left cell is on the left
    for j in range(rows):
        for i in range(cols - 1):
            a, b = ((i + 1) * sx, j * sy), ((i + 1) * sx, (j + 1) * sy)
            k = knob(sy, sx, [(i, j), (i + 1, j)])
            vert[i, j] = shared_edge(a, b, k and k[0], k and sy // 2 + k[1], side(), c)
    parts = []
    for j in range(rows):
        for i in range(cols):
            x0, y0, x1, y1 = i * sx, j * sy, (i + 1) * sx, (j + 1) * sy
            bottom = horiz[i, j - 1][0] if j > 0 else [(x0, y0), (x1, y0)]
            right = vert[i, j][0] if i < cols - 1 else [(x1, y0), (x1, y1)]
            top = horiz[i, j][1] if j < rows - 1 else [(x1, y1), (x0, y1)]
            left = vert[i - 1, j][1] if i > 0 else [(x0, y1), (x0, y0)]
            parts.append(make_part(f"k{j}_{i}", [*bottom, *right, *top, *left]))
    return parts


KNOBS = Family(
    "knobs", "Jigsaw-like cells with trapezoid, rectangular, round, V or stepped knobs (no dovetails).",
    (Option("rows", "Rows of cells.", 1, 8, draw_low=2, draw_high=3),
     Option("cols", "Columns of cells.", 1, 8, draw_low=2, draw_high=4),
     Option("shape", "Knob shape (mixed: drawn per edge).", choices=(*SHAPES, "mixed")),
     Option("clearance", "Gap between a knob and its socket.", 0, 3, draw_low=0, draw_high=2),
     Option("knob_pct", "Percentage of internal edges with a knob (a cell keeps at most 3).", 0, 100,
            default=80)),
    _knobs, _count, ("rows", "cols"))
