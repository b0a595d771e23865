"""The geometric descriptors of many operations at once, from per-part and per-pair tables.

``BatchDescriptors(assembly).of(ops) -> float32 [N, len(DESCRIPTORS)]`` gives the numbers of
``rap.model.data.descriptors`` (same names, order and definitions) for a batch of operations of
one assembly, without a shapely union or boundary intersection per operation:

* the maximal removal range comes from the same exact NDBG: each cell's blocking relation is kept
  as a 0/1 matrix, so whether a batch's (moving, fixed) partitions are free in every cell is two
  matrix products; the run of free cells around the operation's cell, and its bounding exact
  directions, are then read off as ``DescriptorContext.removal_range`` walks them (the same
  cells, the same exact end directions compared for equality);
* areas, perimeters and contacts are sums over parts and pairs of parts, because the parts of an
  assembly do not overlap: the union's area is the sum of its parts', its boundary length the sum
  of their perimeters less twice the contacts between them, and the common boundary of the
  moving and the fixed subassembly is the union of the contacts of (moving part, fixed part)
  pairs (one shapely boundary intersection per touching pair, once per assembly);
* the extents along and across the motion are extremes of the parts' outer vertices (those of
  the union's exterior are among them, or lie on their edges).

Contract: for a feasible operation the result equals ``descriptors_for(DescriptorContext(a),
ops)`` to float rounding (``tests/model/data/test_batch_descriptors.py``); an infeasible one
raises ``ValueError`` as there. Inputs of a learned model, never predicates.

Cost: the NDBG and one shapely intersection per pair of parts whose boxes touch, once per
assembly (milliseconds for tens of parts); then per operation a few microseconds of Python (its
parts' indices, its cell) and O(cells x parts^2 + contacts + vertices) vectorised numpy work,
about 10-20 times cheaper than ``DescriptorContext.descriptors`` on the 22-brick wall
(``python benchmarks/scorer.py``). Not thread-safe (lazily built tables). No torch, no ray.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence

import numpy as np

from rap.assembly import Assembly
from rap.geometry.ndbg import NDBG, cell_index, ndbg_of
from rap.model.data.descriptors import DESCRIPTORS, PARALLEL_COS, VERTEX_RAD, segments
from rap.operation import Operation

__all__ = ["BatchDescriptors"]

_TWO_PI = 2.0 * math.pi


class BatchDescriptors:
    """One assembly's tables for ``of(ops)`` (module doc). Memory: cells x parts^2 bytes for the
    blocking matrices, plus the parts' vertices and the contact segments."""

    def __init__(self, assembly: Assembly, ndbg: NDBG | None = None):
        self.assembly = assembly
        self.ndbg = ndbg if ndbg is not None else ndbg_of(assembly)
        g = self.ndbg
        self.ids = list(g.ids)
        self.index = {pid: i for i, pid in enumerate(self.ids)}
        n, cells = len(self.ids), g.cells
        k = len(cells)
        blocked = np.zeros((k, n, n), dtype=np.float32)  # [cell, moving part, blocking part]
        for c, cell in enumerate(cells):
            for i, m in enumerate(cell.outs):
                while m:
                    low = m & -m
                    blocked[c, i, low.bit_length() - 1] = 1.0
                    m ^= low
        self._blocked = blocked.transpose(1, 0, 2).reshape(n, k * n)  # M @ this: [N, k*n]
        # each cell's lower and upper bounding direction (a vertex: its own), as angles and as
        # ids of the exact directions (equal ids <=> equal exact vectors)
        ids: dict = {}
        lo, hi = [], []
        for cell in cells:
            a = cell.direction if cell.kind == "vertex" else cell.start
            b = cell.direction if cell.kind == "vertex" else cell.end
            lo.append(a)
            hi.append(b)
        self._lo_id = np.array([ids.setdefault(d, len(ids)) for d in lo])
        self._hi_id = np.array([ids.setdefault(d, len(ids)) for d in hi])
        self._lo_angle = np.array([_angle(d) if d is not None else 0.0 for d in lo])
        self._hi_angle = np.array([_angle(d) if d is not None else 0.0 for d in hi])
        self._vertex = np.array([c.kind == "vertex" for c in cells])
        self._vertex_angle = np.array([_angle(c.direction) for c in cells])
        self._cells: dict = {}  # an operation's direction -> the cell of its removal direction
        self._shapes()

    def _shapes(self) -> None:
        from shapely.geometry import Polygon

        parts = [self.assembly.part(pid) for pid in self.ids]
        polys = [Polygon(p.float_outer(), p.float_holes()) for p in parts]
        self._area = np.array([p.area for p in polys])
        self._perimeter = np.array([p.length for p in polys])
        outer = [np.asarray(p.float_outer(), dtype=np.float64) for p in parts]
        self._verts = np.concatenate(outer)
        self._vert_part = np.concatenate([np.full(len(v), i) for i, v in enumerate(outer)])
        boxes = np.array([p.bounds for p in polys])
        seg_i, seg_j, seg = [], [], []
        n = len(polys)
        for i in range(n):
            for j in range(i + 1, n):
                if (boxes[i, 0] > boxes[j, 2] or boxes[j, 0] > boxes[i, 2]
                        or boxes[i, 1] > boxes[j, 3] or boxes[j, 1] > boxes[i, 3]):
                    continue
                for s in segments(polys[i].boundary.intersection(polys[j].boundary)):
                    seg_i.append(i)
                    seg_j.append(j)
                    seg.append((s[2] - s[0], s[3] - s[1]))
        self._seg_i = np.array(seg_i, dtype=np.int64)
        self._seg_j = np.array(seg_j, dtype=np.int64)
        d = np.array(seg, dtype=np.float64).reshape(-1, 2)
        self._seg_d = d
        self._seg_len = np.hypot(d[:, 0], d[:, 1])

    def _masks(self, ops: Sequence[Operation]) -> tuple[np.ndarray, np.ndarray]:
        n = len(self.ids)
        moving = np.zeros((len(ops), n), dtype=np.float32)
        fixed = np.zeros((len(ops), n), dtype=np.float32)
        index = self.index
        for r, op in enumerate(ops):
            moving[r, [index[p] for p in op.moving]] = 1.0
            fixed[r, [index[p] for p in op.fixed]] = 1.0
        return moving, fixed

    @staticmethod
    def _removal(op: Operation) -> tuple[Fraction, Fraction]:
        """The exact removal direction (the float one taken exactly when none is carried)."""
        if op.exact_direction is not None:
            return (-Fraction(op.exact_direction[0]), -Fraction(op.exact_direction[1]))
        return (Fraction(-op.direction[0]), Fraction(-op.direction[1]))

    def _cell(self, op: Operation, free: np.ndarray) -> int:
        """The operation's cell (``DescriptorContext.removal_range``'s ``k0``): the cell of its
        exact removal direction, or of its float one, a vertex beside it standing for it."""
        key = op.exact_direction if op.exact_direction is not None else op.direction
        k0 = self._cells.get(key)
        if k0 is None:
            k0 = self._cells[key] = cell_index(self.ndbg, self._removal(op))
        if free[k0]:
            return k0
        removal = self._removal(op)
        if op.exact_direction is None:
            a = _angle(removal)
            k = len(free)
            for c in ((k0 - 1) % k, (k0 + 1) % k):
                d = abs(self._vertex_angle[c] - a)
                if self._vertex[c] and free[c] and min(d, _TWO_PI - d) < VERTEX_RAD:
                    return c
        raise ValueError(f"moving {sorted(op.moving)} is blocked by {sorted(op.fixed)} along "
                         f"{tuple(float(v) for v in removal)}")

    def of(self, ops: Sequence[Operation]) -> np.ndarray:
        """float32 [N, len(DESCRIPTORS)] of feasible operations of this assembly (module doc)."""
        ops = list(ops)
        out = np.zeros((len(ops), len(DESCRIPTORS)), dtype=np.float32)
        if not ops:
            return out
        moving, fixed = self._masks(ops)
        nk = len(self.ndbg.cells)
        n = len(self.ids)
        hits = (moving @ self._blocked).reshape(len(ops), nk, n)
        free = np.einsum("rkj,rj->rk", hits, fixed) == 0  # [N, cells]
        k0 = np.array([self._cell(op, free[r]) for r, op in enumerate(ops)])
        width, margin, single = self._ranges(ops, free, k0)
        r = -np.array([op.direction for op in ops], dtype=np.float64)  # removal directions
        out[:, 0] = width
        out[:, 1] = margin
        half = width / 2
        out[:, 2] = np.where(width > 0, margin / np.where(width > 0, half, 1.0), 0.0)
        out[:, 3] = single
        out[:, 4] = moving.sum(axis=1)
        out[:, 5] = fixed.sum(axis=1)
        am, af = moving @ self._area, fixed @ self._area
        out[:, 6] = np.log(am / (am + af))
        self._contacts(moving, fixed, r, out)
        self._extents(moving, fixed, r, out)
        return out

    def _ranges(self, ops, free: np.ndarray, k0: np.ndarray):
        """(width, margin, single) of each operation's maximal free range (``removal_range``)."""
        nr, nk = free.shape
        rows = np.arange(nr)
        ahead = free[rows[:, None], (k0[:, None] + np.arange(1, nk)) % nk]  # k0+1, k0+2, ...
        behind = free[rows[:, None], (k0[:, None] - np.arange(1, nk)) % nk]  # k0-1, k0-2, ...
        # removal_range walks back at most nk-1 cells (all free: the whole circle), then ahead
        back = np.where(behind.all(axis=1), nk - 1, np.argmin(behind, axis=1))
        whole = back == nk - 1
        fwd = np.where(ahead.all(axis=1), nk - 1, np.argmin(ahead, axis=1))
        first, last = (k0 - back) % nk, (k0 + fwd) % nk
        same = self._lo_id[first] == self._hi_id[last]
        ra = np.array([math.atan2(-op.direction[1], -op.direction[0]) for op in ops])
        lo, hi = self._lo_angle[first], self._hi_angle[last]
        width = (hi - lo) % _TWO_PI
        margin = np.minimum(np.minimum((ra - lo) % _TWO_PI, (hi - ra) % _TWO_PI), width / 2)
        width = np.where(same, 0.0, width)
        margin = np.where(same, 0.0, margin)
        width = np.where(whole, _TWO_PI, width)
        margin = np.where(whole, math.pi, margin)
        single = (same & ~whole).astype(np.float32)
        return width, margin, single

    def _contacts(self, moving, fixed, r, out) -> None:
        """Sliding and facing contact over the moving perimeter (columns 7, 8)."""
        si, sj = self._seg_i, self._seg_j
        across_pair = moving[:, si] * fixed[:, sj] + moving[:, sj] * fixed[:, si]  # [N, S]
        inside = moving[:, si] * moving[:, sj]
        length = self._seg_len
        perimeter = moving @ self._perimeter - 2.0 * (inside @ length)
        d = self._seg_d
        c = np.abs(r[:, :1] * d[:, 0] + r[:, 1:] * d[:, 1]) / length  # [N, S]
        parallel = c > PARALLEL_COS
        sliding = (across_pair * parallel) @ length if len(length) else 0.0
        cross = length * np.sqrt(np.maximum(0.0, 1.0 - c * c))
        facing = (across_pair * ~parallel * cross).sum(axis=1)
        out[:, 7] = sliding / perimeter
        out[:, 8] = facing / perimeter

    def _extents(self, moving, fixed, r, out) -> None:
        """Depth, lateral overlap and aspect (columns 9-11) from the parts' outer vertices."""
        v = self._verts
        along = v @ r.T  # [V, N]
        across = v @ np.stack([-r[:, 1], r[:, 0]])
        mv = moving[:, self._vert_part].T > 0  # [V, N]
        fv = fixed[:, self._vert_part].T > 0
        inf = np.inf
        ma_min = np.where(mv, along, inf).min(axis=0)
        ma_max = np.where(mv, along, -inf).max(axis=0)
        fa_max = np.where(fv, along, -inf).max(axis=0)
        mc_min = np.where(mv, across, inf).min(axis=0)
        mc_max = np.where(mv, across, -inf).max(axis=0)
        fc_min = np.where(fv, across, inf).min(axis=0)
        fc_max = np.where(fv, across, -inf).max(axis=0)
        length_along = np.maximum(ma_max - ma_min, 1e-12)
        width_across = np.maximum(mc_max - mc_min, 1e-12)
        extent = np.maximum(length_along, width_across)
        out[:, 9] = np.maximum(0.0, fa_max - ma_min) / extent
        lateral = np.maximum(0.0, np.minimum(mc_max, fc_max) - np.maximum(mc_min, fc_min))
        out[:, 10] = lateral / width_across
        out[:, 11] = np.log(width_across / length_along)


def _angle(v) -> float:
    return math.atan2(float(v[1]), float(v[0]))
