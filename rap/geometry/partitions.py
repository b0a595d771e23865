"""Partitions of a subassembly from the NDBG: RAP's online choice, all of them, interlocking.

For a subassembly S and a cell, the feasible moving sets are the nonempty proper subsets M of S
closed under the out-edges of the cell's DBG restricted to S (no part of M is blocked by a part
of S \\ M): the ideals of the condensation of that DBG. A feasible (M, S \\ M) is feasible in a
set of cells; maximal runs of consecutive cells (cyclically, across angle 0 too) form maximal
direction ranges. ``Partition.removal_unit`` is the angular middle of its range (the vertex's
direction for a single vertex), and its exact counterpart ``direction`` is verified exactly to be
strictly inside the range (an exact interior vector replaces it if floats ever fall outside).

* ``online_partitions`` is RAP's choice: per cell the sink strongly connected component (of the
  DBG restricted to S) containing the smallest part index among the sink components (none when
  that component is S itself), then equal choices of adjacent cells merged. Per cell O(|S|) big-
  int operations when the restricted DBG is acyclic (sinks are the parts blocked by nobody; a
  backward closure from them over in-bitmasks proves there is no other sink component), O(|S|^2)
  otherwise; cells whose restricted DBG did not change are skipped.
* ``all_partitions`` enumerates the ideals of every distinct restricted DBG (O(|S|) per ideal),
  deduplicates them as (moving, fixed, maximal range), optionally samples ``limit`` of them
  uniformly with the given ``np.random.Generator``. The count can be exponential in |S|; more than
  ``max_count`` (moving set, cell run) incidences raise
  ``rap.geometry.moving_sets.TooManyPartitions``.
* ``single_part_partitions``: the partitions that move one part: per part of S, the maximal runs
  of cells where nothing else of S blocks it (O(cells x |S|) bit operations): the operation
  space of a cell that inserts one part at a time (the online choice may offer none of them).
* ``interlocked``: no feasible partition in any cell (the planner names a minimal interlocked
  subassembly with ``rap.plan.interlocked``).
* ``cell_partition_counts``: the number of feasible moving sets per cell (capped; pictures).
* ``range_partition``: the ``Partition`` of a moving set over a run of cells (exact bounds, exact
  middle direction).

The bitmask work (closures, the cells where a restricted DBG changes, ideals) lives in
``rap.geometry.moving_sets``.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable

from rap.geometry.exact import IVec, angle_key, in_open_arc, open_arc_middle, primitive
from rap.geometry.moving_sets import (TooManyPartitions, cell_segments, changed_cells, closure,
                                      ideals, subset_mask)
from rap.geometry.ndbg import NDBG
from rap.operation import Operation

__all__ = ["Partition", "range_partition", "online_partitions", "single_part_partitions",
           "all_partitions",
           "partition_specs", "spec_is_vertex", "interlocked",
           "cell_partition_counts", "DEFAULT_MAX_COUNT"]

DEFAULT_MAX_COUNT = 2_000_000


@dataclass(frozen=True)
class Partition:
    """(moving, fixed) separable by translating ``moving`` along any direction of its range.

    ``range_start``/``range_end``: exact integer bounds of the maximal merged direction range
    (CCW from start to end; equal for a single vertex); ``start_closed``/``end_closed`` tell
    whether the bound direction itself belongs to the range. ``span`` is 'vertex', 'range' or
    'circle' (every direction; bounds are then (1, 0)). ``direction`` is the exact removal
    direction, ``removal_unit`` its float unit vector (the middle of the range).
    """

    moving: frozenset[str]
    fixed: frozenset[str]
    range_start: IVec
    range_end: IVec
    removal_unit: tuple[float, float]
    direction: IVec
    span: str = "range"
    start_closed: bool = False
    end_closed: bool = False

    def operation(self) -> Operation:
        """The assembly operation: ``moving`` travels along -removal_unit to its place."""
        ux, uy = self.removal_unit
        dx, dy = self.direction
        return Operation(self.moving, self.fixed, (-ux, -uy), (Fraction(-dx), Fraction(-dy)))

    def contains(self, d) -> bool:
        """Is the exact direction d in this partition's range?"""
        if self.span == "circle":
            return True
        p = primitive(d)
        if self.span == "vertex":
            return p == self.range_start
        if (self.start_closed and p == self.range_start) or (self.end_closed and p == self.range_end):
            return True
        return in_open_arc(p, self.range_start, self.range_end)


def range_partition(ndbg: NDBG, moving: int, m: int, kf: int, kl: int, whole: bool) -> Partition:
    """The partition of S = m moving the parts of mask ``moving`` in every direction of the cells
    ``kf`` to ``kl`` (CCW; the whole circle when ``whole``), with its exact range bounds and its
    middle direction, exact and strictly inside. O(1) big-int operations besides the names."""
    mov = ndbg.names(moving)
    fix = ndbg.names(m & ~moving)
    cells = ndbg.cells
    if whole:
        d = (0, 1)
        return Partition(mov, fix, (1, 0), (1, 0), (0.0, 1.0), d, "circle", True, True)
    a, b = cells[kf], cells[kl]
    if kf == kl and a.kind == "vertex":
        return Partition(mov, fix, a.direction, a.direction, a.unit, a.direction, "vertex",
                         True, True)
    if a.kind == "vertex":
        s, s_closed = a.direction, True
    else:
        s, s_closed = a.start, False
    if b.kind == "vertex":
        e, e_closed = b.direction, True
    else:
        e, e_closed = b.end, False
    d, u = open_arc_middle(s, e)
    return Partition(mov, fix, s, e, u, d, "range", s_closed, e_closed)


def _runs(values: list[int]) -> list[tuple[int, int, int, bool]]:
    """Maximal cyclic runs (value, first, last, covers_all) of equal nonzero values."""
    N = len(values)
    if all(v == values[0] for v in values):
        return [(values[0], 0, N - 1, True)] if values[0] else []
    k0 = next(k for k in range(N) if values[k] != values[k - 1])
    runs = []
    start = k0
    cur = values[k0]
    for t in range(1, N + 1):
        k = (k0 + t) % N
        if t == N or values[k] != cur:
            if cur:
                runs.append((cur, start, (k - 1) % N, False))
            start, cur = k, values[k]
    return runs


def _online_choice(out, inn, idx, m) -> int:
    Z = 0
    for v in idx:
        if not out[v] & m:
            Z |= 1 << v
    seen = closure(Z, inn, m)
    best = Z & -Z
    if seen != m:
        R = m & ~seen  # closed under out-edges: every other sink component lies in R
        done = 0
        rest = R
        limit_bit = best.bit_length() - 1 if best else len(out)
        while rest:
            low = rest & -rest
            v = low.bit_length() - 1
            if v > limit_bit:
                break
            F = closure(low, out, R)
            B = closure(low, inn, F)
            if B == F:
                best = B
                break
            done |= B
            rest &= ~done
    if best == m:
        return 0
    return best


def online_partitions(ndbg: NDBG, subset: Iterable[str]) -> list[Partition]:
    """RAP's online choice: one partition per cell, equal choices of adjacent cells merged.

    Returned in the CCW order of the range starts from angle 0. Empty when S has one part or is
    interlocked.
    """
    m, idx = subset_mask(ndbg, subset)
    if len(idx) < 2:
        return []
    cells = ndbg.cells
    N = len(cells)
    out0 = cells[0].outs
    inn = [0] * ndbg.n
    for i in idx:
        mm = out0[i] & m
        while mm:
            low = mm & -mm
            inn[low.bit_length() - 1] |= 1 << i
            mm ^= low
    rows = ndbg.toggle_rows
    choice = [0] * N
    cur = _online_choice(out0, inn, idx, m)
    choice[0] = cur
    last = 0
    for k in changed_cells(ndbg, m):
        for t in range(last + 1, k):
            choice[t] = cur
        for i, jm in rows[k][1]:
            if m >> i & 1:
                jm &= m
                bit = 1 << i
                while jm:
                    low = jm & -jm
                    inn[low.bit_length() - 1] ^= bit
                    jm ^= low
        cur = _online_choice(cells[k].outs, inn, idx, m)
        choice[k] = cur
        last = k
    for t in range(last + 1, N):
        choice[t] = cur
    parts = [range_partition(ndbg, mv, m, kf, kl, whole) for mv, kf, kl, whole in _runs(choice)]
    parts.sort(key=lambda p: angle_key(p.range_start))
    return parts


def single_part_partitions(ndbg: NDBG, subset: Iterable[str]) -> list[Partition]:
    """Every partition of S whose moving side is one part, over each maximal run of cells where
    the rest of S does not block that part (CCW order of range starts, then part order). Empty
    when S has one part. O(cells x |S|) big-int operations."""
    m, idx = subset_mask(ndbg, subset)
    if len(idx) < 2:
        return []
    parts = []
    for i in idx:
        bit = 1 << i
        others = m & ~bit
        free = [0 if cell.outs[i] & others else bit for cell in ndbg.cells]
        parts += [range_partition(ndbg, mv, m, kf, kl, whole) for mv, kf, kl, whole in _runs(free)]
    parts.sort(key=lambda p: angle_key(p.range_start))
    return parts


def cell_partition_counts(ndbg: NDBG, subset: Iterable[str], cap: int = 100_000) -> list[int]:
    """Per cell, the number of feasible moving sets of S (capped at ``cap``), for pictures."""
    m, idx = subset_mask(ndbg, subset)
    cells = ndbg.cells
    if len(idx) < 2:
        return [0] * len(cells)
    firsts = [0] + changed_cells(ndbg, m)
    counts = [0] * len(cells)
    memo: dict[tuple, int] = {}
    r = [0] * ndbg.n
    for a, k in enumerate(firsts):
        sig = tuple(cells[k].outs[v] & m for v in idx)
        c = memo.get(sig)
        if c is None:
            for v, o in zip(idx, sig):
                r[v] = o
            c = memo[sig] = min(cap, ideals(idx, r, m, cap, count_only=True))
        end = firsts[a + 1] if a + 1 < len(firsts) else len(cells)
        for t in range(k, end):
            counts[t] = c
    return counts


def partition_specs(ndbg: NDBG, subset: Iterable[str], max_count: int = DEFAULT_MAX_COUNT
                    ) -> list[tuple[int, int, int, bool]]:
    """Every feasible partition of S as ``(moving mask, first cell, last cell, whole circle)``.

    The integer core of ``all_partitions`` (no floats, no objects): one tuple per (moving set,
    maximal direction range), in no particular order. Raises ``TooManyPartitions`` past ``max_count`` (moving set, cell run)
    incidences. Cost: O(|S|) per ideal of every distinct restricted DBG.
    """
    m, idx = subset_mask(ndbg, subset)
    if len(idx) < 2:
        return []
    cells = ndbg.cells
    N = len(cells)
    seg_first, seg_last = cell_segments(ndbg, m)
    S = len(seg_first)
    memo: dict[tuple, list[int]] = {}
    where: dict[int, list[int]] = {}
    count = 0
    r = [0] * ndbg.n
    for s, k in enumerate(seg_first):
        sig = tuple(cells[k].outs[v] & m for v in idx)
        sets = memo.get(sig)
        if sets is None:
            for v, o in zip(idx, sig):
                r[v] = o
            sets = ideals(idx, r, m, max_count)
            memo[sig] = sets
        count += len(sets)
        if count > max_count:
            raise TooManyPartitions(f"more than {max_count} partitions to enumerate")
        for mv in sets:
            where.setdefault(mv, []).append(s)
    specs: list[tuple[int, int, int, bool]] = []
    for mv, segs in where.items():
        if len(segs) == S:
            specs.append((mv, 0, N - 1, True))
            continue
        present = set(segs)
        for s in segs:
            if (s - 1) % S in present:
                continue  # not the start of a run
            t = s
            while (t + 1) % S in present:
                t = (t + 1) % S
            specs.append((mv, seg_first[s], seg_last[t], False))
    return specs


def spec_is_vertex(ndbg: NDBG, spec: tuple[int, int, int, bool]) -> bool:
    """Does the spec's range hold a single direction (one vertex cell)?"""
    _, kf, kl, whole = spec
    return not whole and kf == kl and ndbg.cells[kf].kind == "vertex"


def all_partitions(ndbg: NDBG, subset: Iterable[str], limit: int | None = None, rng=None,
                   max_count: int = DEFAULT_MAX_COUNT) -> list[Partition]:
    """Every feasible partition of S, deduplicated as (moving, fixed, maximal direction range).

    Sorted by (sorted moving ids, range start angle). With ``limit`` and more partitions than
    that, a uniform sample of ``limit`` of them drawn with ``rng`` (an ``np.random.Generator``,
    required then), still in that order. Raises ``TooManyPartitions`` past ``max_count``
    (moving set, cell run) incidences.
    """
    if limit is not None and rng is None:
        raise ValueError("all_partitions: rng is required when limit is given")
    m, idx = subset_mask(ndbg, subset)
    if len(idx) < 2:
        return []
    result = [range_partition(ndbg, mv, m, kf, kl, whole)
              for mv, kf, kl, whole in partition_specs(ndbg, subset, max_count)]
    result.sort(key=lambda p: (sorted(p.moving), angle_key(p.range_start)))
    if limit is not None and len(result) > limit:
        pick = sorted(int(i) for i in rng.choice(len(result), size=limit, replace=False))
        result = [result[i] for i in pick]
    return result


def interlocked(ndbg: NDBG, subset: Iterable[str]) -> bool:
    """True when S (two or more parts) has no feasible partition in any cell."""
    subset = list(subset)
    return len(subset) >= 2 and not online_partitions(ndbg, subset)
