"""The non-directional blocking graph (NDBG) of one-step translations, built by a sweep.

``build_ndbg(assembly)`` scales the assembly to integers, splits every part into convex pieces
(a hierarchy of them per part, ``rap.geometry.blocking.piece_tree``), computes for every unordered
pair of parts the disjoint open blocking arcs of (a, b) (those of
(b, a) are their negation) and sweeps the circle of directions once over the sorted critical
directions (arc endpoints). Each ordered pair's blocked set is a union of *disjoint* open arcs,
so a pair is blocked in at most one of its arcs at a time: the sweep keeps one bit per ordered
pair (per-part out-bitmasks), clears the bits of arcs ending at a critical direction (giving
that direction's vertex cell) and then sets the bits of arcs starting there (giving the next
arc cell). The state at the first critical direction is found by testing every arc once.

Cells are listed CCW from angle 0 (the +x axis): the cell containing angle 0 comes first, i.e.
the vertex at angle 0 if it is critical, otherwise the arc that wraps around angle 0. With no
critical directions at all there is a single arc cell: the full circle.

Each cell stores its DBG as a tuple of per-part out-bitmasks (``outs[i]`` has bit j when moving
part i alone along the cell's directions collides with part j); consecutive cells share the
int objects of unchanged rows. ``Cell.blocks`` materialises the index pairs on demand.

Complexity (n parts, at most q vertices per part): O(n^2 q^2) for the cones at worst, O(n^2 q)
where parts apart take their hulls' cone (``rap.geometry.blocking``; a 91-piece jigsaw of 36,922
vertices in 4 s), O(m log m) to sort the m = O(n^2) critical directions (m = O(n^2 q^2)
for non-convex parts), O(m n) to snapshot the cells, i.e. O(n^2 (log n + q^2)) as in the paper
plus the O(n^3) output of the explicit per-cell DBGs.
"""

from __future__ import annotations

import bisect
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Iterable, Sequence

from rap.assembly import Assembly
from rap.geometry.blocking import BlockedSet, piece_tree, tree_blocking_arcs
from rap.geometry.exact import (IVec, angle_key, arc_interior_vector, arc_middle_unit,
                                exact_direction, in_open_arc, primitive, to_integers, unit)
from rap.geometry.validation import assembly_pieces

__all__ = ["Cell", "NDBG", "build_ndbg", "build_ndbg_from_pieces", "ndbg_of", "cell_index",
           "cell_at", "blocked_at", "is_feasible_operation", "is_free_operation"]


@dataclass(frozen=True, eq=False)
class Cell:
    """One cell of the NDBG: a critical direction ('vertex') or an open arc between two."""

    kind: str
    direction: IVec
    unit: tuple[float, float]
    outs: tuple[int, ...] = field(repr=False)
    start: IVec | None = None  # arc cells: bounding critical directions (None: full circle)
    end: IVec | None = None

    @property
    def blocks(self) -> frozenset[tuple[int, int]]:
        """Index pairs (i, j): moving part i alone along these directions collides with j."""
        out = []
        for i, m in enumerate(self.outs):
            while m:
                low = m & -m
                out.append((i, low.bit_length() - 1))
                m ^= low
        return frozenset(out)

    def contains(self, d: Sequence[int]) -> bool:
        if self.kind == "vertex":
            return primitive(d) == self.direction
        if self.start is None:
            return True
        return in_open_arc(d, self.start, self.end)


@dataclass(frozen=True, eq=False)
class NDBG:
    """Cells CCW from angle 0, the sorted critical directions and the pair blocking sets.

    ``toggles[k]`` lists the ordered pairs ``(i, j)`` whose blocking changes from cell k-1 to
    cell k (cyclically; for k = 0 from the last cell), for incremental sweeps.
    """

    ids: tuple[str, ...]
    cells: tuple[Cell, ...]
    criticals: tuple[IVec, ...]
    toggles: tuple[tuple[tuple[int, int], ...], ...] = field(repr=False)
    pair_blocking: dict = field(repr=False, default_factory=dict)
    name: str = "assembly"
    scale: int = 1

    @property
    def n(self) -> int:
        return len(self.ids)

    def index(self, part_id: str) -> int:
        return self.ids.index(part_id)

    def mask(self, ids: Iterable[str]) -> int:
        pos = {p: i for i, p in enumerate(self.ids)}
        m = 0
        for p in ids:
            m |= 1 << pos[p]
        return m

    def names(self, mask: int) -> frozenset[str]:
        out = []
        while mask:
            low = mask & -mask
            out.append(self.ids[low.bit_length() - 1])
            mask ^= low
        return frozenset(out)

    @property
    def _keys(self) -> list:
        k = self.__dict__.get("_angle_keys")
        if k is None:
            k = [angle_key(c) for c in self.criticals]
            object.__setattr__(self, "_angle_keys", k)
        return k

    @property
    def toggle_rows(self) -> tuple[tuple[int, tuple[tuple[int, int], ...]], ...]:
        """Per cell: (mask of parts i with a toggled edge, ((i, mask of toggled j), ...))."""
        rows = self.__dict__.get("_toggle_rows")
        if rows is None:
            rows = []
            for tg in self.toggles:
                acc: dict[int, int] = {}
                for i, j in tg:
                    acc[i] = acc.get(i, 0) | (1 << j)
                src = 0
                for i in acc:
                    src |= 1 << i
                rows.append((src, tuple(acc.items())))
            rows = tuple(rows)
            object.__setattr__(self, "_toggle_rows", rows)
        return rows

    @property
    def toggle_pairs(self) -> tuple:
        """The toggled pairs of every cell as three int64 numpy arrays ``(cell, i, j)`` (cell 0
        included), for vectorised sweeps (``rap.geometry.moving_sets.changed_cells``)."""
        arrays = self.__dict__.get("_toggle_pairs")
        if arrays is None:
            import numpy as np

            flat = [(k, i, j) for k, tg in enumerate(self.toggles) for i, j in tg]
            table = np.array(flat, dtype=np.int64).reshape(-1, 3)
            arrays = (table[:, 0].copy(), table[:, 1].copy(), table[:, 2].copy())
            object.__setattr__(self, "_toggle_pairs", arrays)
        return arrays

    @property
    def offset(self) -> int:
        """0 when the first critical direction is angle 0 (vertex first), else 1."""
        return 0 if not self.criticals or self.criticals[0] == (1, 0) else 1


def _snapshot_cells(n: int, pairs: dict[tuple[int, int], BlockedSet]):
    starts: dict[IVec, list[tuple[int, int]]] = {}
    ends: dict[IVec, list[tuple[int, int]]] = {}
    out = [0] * n
    always: list[tuple[int, int]] = []
    arcs: list[tuple[int, int, IVec, IVec]] = []
    for (i, j), bs in pairs.items():
        if bs.full:
            always.append((i, j))
            continue
        for s, e in bs.arcs:
            starts.setdefault(s, []).append((i, j))
            ends.setdefault(e, []).append((i, j))
            arcs.append((i, j, s, e))
    for i, j in always:
        out[i] |= 1 << j
    crit = sorted(set(starts) | set(ends), key=angle_key)
    m = len(crit)
    if m == 0:
        cell = Cell("arc", (1, 0), (1.0, 0.0), tuple(out))
        return [cell], [], [()]
    c0 = crit[0]
    for i, j, s, e in arcs:  # the state at the first critical direction
        if in_open_arc(c0, s, e):
            out[i] |= 1 << j
    seq: list[Cell] = []
    tog: list[tuple] = []
    prev_tog: tuple = ()
    for k in range(m):
        c = crit[k]
        if k:
            ch = ends.get(c, ())
            for i, j in ch:
                out[i] &= ~(1 << j)
            prev_tog = tuple(ch)
        seq.append(Cell("vertex", c, unit(c), tuple(out)))
        tog.append(prev_tog)
        ch = starts.get(c, ())
        for i, j in ch:
            out[i] |= 1 << j
        nxt = crit[(k + 1) % m]
        seq.append(Cell("arc", arc_interior_vector(c, nxt), arc_middle_unit(c, nxt), tuple(out),
                        c, nxt))
        tog.append(tuple(ch))
    tog[0] = tuple(ends.get(c0, ()))
    if c0 != (1, 0):  # the arc wrapping around angle 0 comes first
        seq.insert(0, seq.pop())
        tog.insert(0, tog.pop())
    return seq, crit, tog


def build_ndbg_from_pieces(ids: Sequence[str], pieces: Sequence[Sequence[Sequence[IVec]]],
                           name: str = "assembly", scale: int = 1) -> NDBG:
    """The NDBG of parts given as convex pieces with integer coordinates (disjoint interiors)."""
    n = len(ids)
    pairs: dict[tuple[int, int], BlockedSet] = {}
    trees = [piece_tree(pc) for pc in pieces] if n > 1 else [None] * n
    for i in range(n):
        ti = trees[i]
        for j in range(i + 1, n):
            bs = tree_blocking_arcs(ti, trees[j])
            if bs:
                pairs[(i, j)] = bs
                pairs[(j, i)] = bs.negated()
    cells, crit, tog = _snapshot_cells(n, pairs)
    return NDBG(tuple(ids), tuple(cells), tuple(crit), tuple(tog), pairs, name, scale)


def build_ndbg(assembly: Assembly) -> NDBG:
    """Exact NDBG of one-step translations of a (valid) assembly; see the module docstring."""
    if len(assembly.parts) < 2:  # one part: no pair, no pieces
        ia = to_integers(assembly)
        return build_ndbg_from_pieces(ia.ids, [[] for _ in ia.parts], assembly.name, ia.scale)
    ia, pieces = assembly_pieces(assembly)
    return build_ndbg_from_pieces(ia.ids, pieces, assembly.name, ia.scale)


_MEMO: OrderedDict[tuple[str, str], NDBG] = OrderedDict()
_MEMO_SIZE = 8
_MEMO_LOCK = threading.Lock()


def ndbg_of(assembly: Assembly) -> NDBG:
    """``build_ndbg(assembly)``, memoised for the last ``_MEMO_SIZE`` assemblies (by geometry hash
    and name): the planner's problem, the descriptors and the plan's reasons share one NDBG of an
    assembly instead of building it each (seconds for parts of hundreds of vertices)."""
    key = (assembly.geometry_hash, assembly.name)
    with _MEMO_LOCK:
        hit = _MEMO.get(key)
        if hit is not None:
            _MEMO.move_to_end(key)
            return hit
    ndbg = build_ndbg(assembly)
    with _MEMO_LOCK:
        _MEMO[key] = ndbg
        while len(_MEMO) > _MEMO_SIZE:
            _MEMO.popitem(last=False)
    return ndbg


def _as_int_direction(d: Sequence) -> IVec:
    if all(isinstance(v, int) for v in d):
        return primitive(d)
    return exact_direction(d)


def cell_index(ndbg: NDBG, direction: Sequence) -> int:
    """Index of the cell containing an exact direction (ints, Fractions or floats). O(log m)."""
    d = _as_int_direction(direction)
    m = len(ndbg.criticals)
    if m == 0:
        return 0
    keys = ndbg._keys
    kd = angle_key(d)
    k = bisect.bisect_left(keys, kd)
    off = ndbg.offset
    if k < m and keys[k] == kd:
        return off + 2 * k  # the vertex cell of critical k
    # strictly between critical k-1 and k (cyclically)
    if k == 0 or k == m:
        return 0 if off == 1 else 2 * m - 1  # the arc wrapping around angle 0
    return off + 2 * (k - 1) + 1


def cell_at(ndbg: NDBG, direction: Sequence) -> Cell:
    return ndbg.cells[cell_index(ndbg, direction)]


def blocked_at(ndbg: NDBG, direction: Sequence) -> tuple[int, ...]:
    """Per-part out-bitmasks of the DBG at an exact direction."""
    return cell_at(ndbg, direction).outs


def is_feasible_operation(ndbg: NDBG, moving_ids: Iterable[str], fixed_ids: Iterable[str],
                          removal_direction: Sequence) -> bool:
    """Can ``moving`` be translated to infinity along the removal direction, ``fixed`` staying?

    True iff no part of moving is blocked by a part of fixed in the cell of that direction.
    The direction is exact (ints or Fractions; a float is taken at its exact binary value).
    """
    if any(isinstance(v, float) for v in removal_direction):
        removal_direction = tuple(Fraction(v) for v in removal_direction)
    outs = blocked_at(ndbg, removal_direction)
    pos = {p: i for i, p in enumerate(ndbg.ids)}
    fixed = 0
    for p in fixed_ids:
        fixed |= 1 << pos[p]
    return not any(outs[pos[p]] & fixed for p in moving_ids)


def is_free_operation(ndbg: NDBG, meeting: Iterable[tuple[str, str]], moving_ids: Iterable[str],
                      fixed_ids: Iterable[str], removal_direction: Sequence) -> bool:
    """Does ``moving``, swept along the removal direction from its place to infinity, never touch
    ``fixed``? True iff no (moving part, fixed part) pair is in ``meeting`` (pairs ``(a, b)`` of
    parts whose closed polygons share a point: ``rap.geometry.contacts.meeting_pairs``) and none
    is blocked in the *closure* of the direction's cell: a pair's blocked set is a union of open
    arcs whose ends are critical directions, so at a critical (vertex) direction the arc cells on
    either side count too, and a swept part that only grazes a fixed one is not free. Exact, as
    ``is_feasible_operation``. O(log cells + |moving| + |meeting|)."""
    if any(isinstance(v, float) for v in removal_direction):
        removal_direction = tuple(Fraction(v) for v in removal_direction)
    moving, fixed = frozenset(moving_ids), frozenset(fixed_ids)
    if any((a in moving and b in fixed) or (a in fixed and b in moving) for a, b in meeting):
        return False
    k = cell_index(ndbg, removal_direction)
    cells = ndbg.cells
    near = (k - 1, k, k + 1) if cells[k].kind == "vertex" else (k,)
    fmask = ndbg.mask(fixed)
    pos = [ndbg.index(p) for p in moving]
    return not any(cells[c % len(cells)].outs[i] & fmask for c in near for i in pos)
