"""Convex tilings from an integer lattice (``convex``) and running-bond brick walls (``wall``).

* ``convex``: a ``rows`` x ``cols`` lattice of vertices jittered by integers in [-jitter, jitter];
  ``cell`` ``quad`` takes its quads, ``tri`` splits each quad along a drawn diagonal, ``hex``
  takes hexagons over a zigzag lattice (rows of cells offset by half a cell, as in a running bond,
  with a quad at each end of the offset rows: a Voronoi-like tiling of the plane's hexagonal
  lattice). Shared vertices stay shared, so neighbours touch along whole edges. A jitter field
  that leaves a cell non-convex is redrawn (at most 100 times, then jitter 0, whose cells are
  convex). Parts: rows x cols (quad), 2 rows x cols (tri), rows x cols + rows // 2 (hex).
* ``wall``: ``rows`` courses of bricks ``2 half`` long and ``height`` high, in running bond: even
  courses hold ``bricks`` bricks, odd ones ``bricks - 1`` bricks between two half bricks, so both
  ends are flush. ``gap`` opens the head joints (the vertical joints inside a course): 0 leaves
  every brick touching its neighbours, a positive gap leaves a slot with clearance. Parts:
  rows x bricks + rows // 2 (``rows=4, bricks=5``: 22 bricks).

Not interlocked by construction: every part is convex, and a finite set of convex parts with
disjoint interiors can be taken apart one part at a time by translations in any given direction
(Guibas and Yao, 1980). Cost: O(parts) (plus the convexity checks of redrawn jitter fields).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["CONVEX", "WALL"]


def _convex_count(o: dict) -> int:
    r, c = o["rows"], o["cols"]
    return {"quad": r * c, "tri": 2 * r * c, "hex": r * c + r // 2}[o["cell"]]


def _is_convex(pts) -> bool:
    n = len(pts)
    for i in range(n):
        a, b, c = pts[i - 1], pts[i], pts[(i + 1) % n]
        if (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]) <= 0:
            return False
    return True


def _cells(o: dict, sx: int, sy: int, jx, jy) -> list[tuple[str, list]]:
    rows, cols, cell = o["rows"], o["cols"], o["cell"]
    if cell in ("quad", "tri"):
        def v(r, c):
            return (c * sx + int(jx[r, c]), r * sy + int(jy[r, c]))

        out = []
        for r in range(rows):
            for c in range(cols):
                q = [v(r, c), v(r, c + 1), v(r + 1, c + 1), v(r + 1, c)]
                if cell == "quad":
                    out.append((f"c{r}_{c}", q))
                elif (r + c) % 2:  # alternate the diagonals (the jitter does the rest)
                    out += [(f"t{r}_{c}a", [q[0], q[1], q[2]]), (f"t{r}_{c}b", [q[0], q[2], q[3]])]
                else:
                    out += [(f"t{r}_{c}a", [q[0], q[1], q[3]]), (f"t{r}_{c}b", [q[1], q[2], q[3]])]
        return out
    # hex: lattice points k * sx/2 along each row boundary, zigzag by +-z (up where k + r is even)
    half = sx // 2
    z = max(2, sy // 6)

    def w(r, k):
        return (k * half + int(jx[r, k]), r * sy + (z if (k + r) % 2 == 0 else -z) + int(jy[r, k]))

    out = []
    for r in range(rows):
        if r % 2 == 0:
            spans = [(2 * j, 2 * j + 2) for j in range(cols)]
        else:
            spans = [(0, 1)] + [(2 * j + 1, 2 * j + 3) for j in range(cols - 1)] + [(2 * cols - 1, 2 * cols)]
        for n, (k0, k1) in enumerate(spans):
            ring = [w(r, k) for k in range(k0, k1 + 1)] + [w(r + 1, k) for k in range(k1, k0 - 1, -1)]
            out.append((f"h{r}_{n}", ring))
    return out


def _convex(rng: np.random.Generator, o: dict) -> list:
    sx = int(rng.integers(14, 25)) // 2 * 2
    sy = int(rng.integers(14, 25))
    jit = min(o["jitter"], min(sx, sy) // 5)
    ncols = 2 * o["cols"] + 1 if o["cell"] == "hex" else o["cols"] + 1
    cells = None
    jit_y = min(jit, max(2, sy // 6) - 1) if o["cell"] == "hex" else jit  # keep the zigzag
    for _ in range(100):
        jx = rng.integers(-jit, jit + 1, size=(o["rows"] + 1, ncols))
        jy = rng.integers(-jit_y, jit_y + 1, size=(o["rows"] + 1, ncols))
        cells = _cells(o, sx, sy, jx, jy)
        if all(_is_convex(ring) for _, ring in cells):
            break
    else:
        zero = np.zeros((o["rows"] + 1, ncols), dtype=int)
        cells = _cells(o, sx, sy, zero, zero)
    return [make_part(pid, ring) for pid, ring in cells]


def _wall_count(o: dict) -> int:
    return o["rows"] * o["bricks"] + o["rows"] // 2


def _wall_problem(o: dict) -> tuple[str, str] | None:
    if o["gap"] > o["half"] - 2:
        return ("gap", f"must be at most half - 2 ({o['half'] - 2}), so that half bricks keep a "
                "width")
    return None


def _wall(rng: np.random.Generator, o: dict) -> list:
    rows, n, half, h, gap = o["rows"], o["bricks"], o["half"], o["height"], o["gap"]
    length = 2 * half
    right = n * length - gap  # both ends of every course are flush
    parts = []
    for r in range(rows):
        y0, y1 = r * h, (r + 1) * h
        if r % 2 == 0:
            xs = [(k * length, k * length + length - gap) for k in range(n)]
        else:
            xs = [(0, half - gap)] + [(half + k * length, half + (k + 1) * length - gap)
                                      for k in range(n - 1)] + [(half + (n - 1) * length, right)]
        for k, (x0, x1) in enumerate(xs):
            parts.append(make_part(f"b{r}_{k}", [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]))
    return parts


CONVEX = Family(
    "convex", "Convex cells over a jittered integer lattice: quads, triangles or hexagons.",
    (Option("rows", "Rows of cells.", 1, 12, draw_low=2, draw_high=4),
     Option("cols", "Cells per row.", 1, 12, draw_low=2, draw_high=4),
     Option("cell", "Cell shape.", choices=("quad", "tri", "hex")),
     Option("jitter", "Largest lattice jitter (at most a fifth of the spacing is used).", 0, 6,
            draw_low=1, draw_high=4)),
    _convex, _convex_count, ("rows", "cols", "cell"))

WALL = Family(
    "wall", "A running-bond brick wall (half bricks at the ends of alternate courses).",
    (Option("rows", "Courses of bricks.", 1, 20, draw_low=2, draw_high=4),
     Option("bricks", "Whole bricks in an even course (odd ones: bricks - 1 and two halves).", 1, 20,
            draw_low=2, draw_high=4),
     Option("half", "Half a brick's length.", 3, 24, draw_low=6, draw_high=10),
     Option("height", "Height of a course.", 2, 30, draw_low=5, draw_high=10),
     Option("gap", "Head-joint gap between neighbouring bricks of a course (0: touching).", 0, 8,
            draw_low=0, draw_high=3)),
    _wall, _wall_count, ("rows", "bricks"), _wall_problem)
