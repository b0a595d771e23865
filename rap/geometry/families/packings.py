"""Rectilinear packings in a tray (``packing``) and polyomino tilings of a rectangle (``polyomino``).

* ``packing``: a U-shaped tray (walls lower than or level with its contents) holding a guillotine
  partition of its inside into rectangles, ``clearance`` narrower than the tray (the slack sits at
  one wall), with ``ells`` pairs of rectangles merged into L-shapes. Parts: ``parts`` (the tray
  included).
* ``polyomino``: a ``cols`` x ``rows`` rectangle of square cells (side ``cell``) tiled by
  ``pieces`` random polyominoes grown from random seed cells, the smallest piece growing first,
  preferring cells that touch the piece on more sides (compact pieces). Parts: ``pieces``.

Not interlocked by verification: a draft is rejected when a piece would have a hole, a pinch or
more than ``MAX_VERTICES`` vertices, or when ``rap.geometry.andor.decomposition`` finds no full
decomposition over online NDBG partitions (rectangles alone in an open tray always pass: they
leave upward one at a time, by Guibas and Yao's theorem for convex parts). At most ``DRAFTS``
drafts, then ``InputError`` (``ParameterError`` naming ``ells`` for packing: options that leave
no room). Cost: O(parts) per draft plus one NDBG
(about O(n^2)) per checked draft; typically one to a few drafts.
"""

from __future__ import annotations

import math

import numpy as np

from rap.assembly import Assembly
from rap.errors import InputError, ParameterError
from rap.geometry.families.base import Family, Option, make_part, ring_points

__all__ = ["PACKING", "POLYOMINO", "union_ring", "MAX_VERTICES", "DRAFTS"]

MAX_VERTICES = 12
DRAFTS = 200


def union_ring(rects) -> list | None:
    """Boundary (counter-clockwise, collinear vertices dropped) of a union of integer rectangles
    ``(x0, y0, x1, y1)`` with disjoint interiors; None when it has a hole, a pinch or several
    components. Traced over unit edges: O(perimeter)."""
    edges: dict[tuple, int] = {}
    for x0, y0, x1, y1 in rects:
        ring = ([(x, y0) for x in range(x0, x1)] + [(x1, y) for y in range(y0, y1)]
                + [(x, y1) for x in range(x1, x0, -1)] + [(x0, y) for y in range(y1, y0, -1)])
        for i, p in enumerate(ring):
            q = ring[(i + 1) % len(ring)]
            if (q, p) in edges:
                del edges[q, p]
            else:
                edges[p, q] = 1
    nxt: dict[tuple, tuple] = {}
    for p, q in edges:
        if p in nxt:
            return None  # a pinch: two boundary edges leave one vertex
        nxt[p] = q
    start = next(iter(nxt))
    pts, p = [start], nxt[start]
    while p != start:
        pts.append(p)
        p = nxt[p]
    if len(pts) != len(nxt):
        return None  # a hole or several components
    return ring_points(pts)


def _decomposable(parts) -> bool:
    from rap.geometry.andor import decomposition
    from rap.geometry.ndbg import build_ndbg

    return decomposition(build_ndbg(Assembly("draft", tuple(parts)))) is not None


# -- packing -----------------------------------------------------------------------------------
def _guillotine(rng: np.random.Generator, w: int, h: int, n: int, m: int) -> list | None:
    rects = [(0, 0, w, h)]
    while len(rects) < n:
        cand = [r for r in rects if r[2] - r[0] >= 2 * m or r[3] - r[1] >= 2 * m]
        if not cand:
            return None
        area = np.array([(r[2] - r[0]) * (r[3] - r[1]) for r in cand], dtype=float)
        r = cand[int(rng.choice(len(cand), p=area / area.sum()))]
        x0, y0, x1, y1 = r
        can_x, can_y = x1 - x0 >= 2 * m, y1 - y0 >= 2 * m
        if can_x and can_y:
            longer_x = x1 - x0 >= y1 - y0
            split_x = longer_x if rng.random() < 0.7 else not longer_x
        else:
            split_x = can_x
        rects.remove(r)
        if split_x:
            s = int(rng.integers(x0 + m, x1 - m + 1))
            rects += [(x0, y0, s, y1), (s, y0, x1, y1)]
        else:
            s = int(rng.integers(y0 + m, y1 - m + 1))
            rects += [(x0, y0, x1, s), (x0, s, x1, y1)]
    return sorted(rects, key=lambda r: (r[1], r[0]))


def _forms_ell(a, b) -> bool:
    """Do rectangles a and b share a whole side of one of them, flush at exactly one end?"""
    for p, q in ((a, b), (b, a)):
        if p[3] == q[1]:  # q on top of p
            lo, hi = max(p[0], q[0]), min(p[2], q[2])
            if hi > lo and (lo, hi) in ((p[0], p[2]), (q[0], q[2])) and (p[0] == q[0]) != (p[2] == q[2]):
                return True
        if p[2] == q[0]:  # q right of p
            lo, hi = max(p[1], q[1]), min(p[3], q[3])
            if hi > lo and (lo, hi) in ((p[1], p[3]), (q[1], q[3])) and (p[1] == q[1]) != (p[3] == q[3]):
                return True
    return False


def _packing(rng: np.random.Generator, o: dict) -> list:
    n_parts, ells, c = o["parts"], o["ells"], o["clearance"]
    n_rects = n_parts - 1 + ells
    for _ in range(DRAFTS):
        aspect = rng.uniform(1.0, 1.8)
        area = n_rects * rng.uniform(150, 260)
        w = max(12, int(math.sqrt(area * aspect)))
        h = max(12, int(area / w))
        rects = _guillotine(rng, w - c, h, n_rects, 6)
        if rects is None:
            continue
        if c and rng.random() < 0.5:  # the slack at the left wall instead of the right one
            rects = [(x0 + c, y0, x1 + c, y1) for x0, y0, x1, y1 in rects]
        t = int(rng.integers(4, 7))
        wall = h - int(rng.integers(0, h // 3 + 1))
        tray = make_part("tray", [(-t, -t), (w + t, -t), (w + t, wall), (w, wall), (w, 0), (0, 0),
                                  (0, wall), (-t, wall)])
        groups = [[r] for r in rects]
        merged = 0
        order = rng.permutation(len(groups) * len(groups)).tolist()
        for code in order:
            if merged == ells:
                break
            i, j = divmod(code, len(groups))
            if i >= j or j >= len(groups) or len(groups[i]) > 1 or len(groups[j]) > 1:
                continue
            if not _forms_ell(groups[i][0], groups[j][0]):
                continue
            trial = [g for k, g in enumerate(groups) if k not in (i, j)] + [groups[i] + groups[j]]
            if _decomposable([tray] + _pieces(trial)):
                groups, merged = trial, merged + 1
        if merged == ells:
            return [tray] + _pieces(sorted(groups, key=lambda g: (g[0][1], g[0][0])))
    raise ParameterError("ells", ells, f"no packing with {ells} L-shapes among {n_parts} parts "
                                       f"found in {DRAFTS} drafts; try fewer")


def _pieces(groups) -> list:
    return [make_part(f"p{k}", union_ring(g)) for k, g in enumerate(groups)]


# -- polyomino ---------------------------------------------------------------------------------
def _grow(rng: np.random.Generator, cols: int, rows: int, n: int) -> list[list[tuple[int, int]]]:
    owner = -np.ones((cols, rows), dtype=int)
    seeds = rng.choice(cols * rows, size=n, replace=False)
    pieces = []
    for k, s in enumerate(seeds.tolist()):
        x, y = divmod(s, rows)
        owner[x, y] = k
        pieces.append([(x, y)])
    free = cols * rows - n

    def neighbours(x, y):
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            if 0 <= x + dx < cols and 0 <= y + dy < rows:
                yield x + dx, y + dy

    while free:
        frontier = {}
        for k, cells in enumerate(pieces):
            f = {}
            for cell in cells:
                for q in neighbours(*cell):
                    if owner[q] < 0:
                        f[q] = sum(owner[r] == k for r in neighbours(*q))
            if f:
                frontier[k] = f
        smallest = min(len(pieces[k]) for k in frontier)
        ks = [k for k in frontier if len(pieces[k]) == smallest]
        k = ks[int(rng.integers(len(ks)))]
        cand = sorted(frontier[k])
        weight = np.array([frontier[k][q] ** 2 for q in cand], dtype=float)
        q = cand[int(rng.choice(len(cand), p=weight / weight.sum()))]
        owner[q] = k
        pieces[k].append(q)
        free -= 1
    return pieces


def _polyomino(rng: np.random.Generator, o: dict) -> list:
    cols, rows, n, u = o["cols"], o["rows"], o["pieces"], o["cell"]
    for _ in range(DRAFTS):
        pieces = _grow(rng, cols, rows, n)
        rings = [union_ring([(x, y, x + 1, y + 1) for x, y in cells]) for cells in pieces]
        if any(r is None or len(r) > MAX_VERTICES for r in rings):
            continue
        order = sorted(range(n), key=lambda k: min((y, x) for x, y in pieces[k]))
        parts = [make_part(f"p{i}", [(x * u, y * u) for x, y in rings[k]]) for i, k in enumerate(order)]
        if _decomposable(parts):
            return parts
    raise InputError(f"polyomino: no tiling of {cols} x {rows} cells by {n} pieces that comes "
                     f"apart found in {DRAFTS} drafts; try more pieces")


PACKING = Family(
    "packing", "Rectangles (and a few L-shapes) packed in an open tray, flush or with slack.",
    (Option("parts", "Parts, the tray included.", 2, 40, draw_low=4, draw_high=12),
     Option("ells", "Pairs of rectangles merged into L-shapes.", 0, 6, draw_low=0, draw_high=2),
     Option("clearance", "Slack between the contents and one wall of the tray.", 0, 6,
            draw_low=0, draw_high=3)),
    _packing, lambda o: o["parts"], ("parts",),
    lambda o: (("ells", f"needs at least {max(3, o['ells'] + 1)} parts")
               if o["ells"] and o["parts"] < max(3, o["ells"] + 1) else None))

POLYOMINO = Family(
    "polyomino", "A rectangle tiled by random compact polyominoes (no holes, at most 12 vertices).",
    (Option("cols", "Cells along x.", 2, 16, draw_low=3, draw_high=6),
     Option("rows", "Cells along y.", 2, 16, draw_low=3, draw_high=5),
     Option("pieces", "Polyominoes.", 2, 40, draw_low=4, draw_high=10),
     Option("cell", "Side of a cell.", 4, 24, draw_low=10, draw_high=14)),
    _polyomino, lambda o: o["pieces"], ("pieces",),
    lambda o: (("pieces", f"more than the {o['cols'] * o['rows']} cells (give cols and rows)")
               if o["pieces"] > o["cols"] * o["rows"] else None))
