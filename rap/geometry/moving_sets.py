"""Feasible moving sets of a subassembly, on bitmasks: the integer core of the partitions.

A subassembly S is a bitmask ``m`` over the NDBG's part indices (``subset_mask``). In one cell,
``r[v]`` is the out-neighbourhood of part v in the DBG restricted to S (the parts of S that block
v's translation); a feasible moving set is a nonempty proper subset of S closed under these
out-edges (no moving part is blocked by a fixed one): an ideal of the restricted DBG.

* ``subset_mask``: the mask and the sorted indices of a set of part ids (``InputError`` for an
  unknown id). O(|S|).
* ``closure``: the parts reachable from a start set over an adjacency of bitmasks, within a mask.
  O(|S|) big-int operations per part reached.
* ``changed_cells`` / ``cell_segments``: the cells where the restricted DBG changes, and the
  maximal runs of cells where it is constant (the DBG of one cell holds for its whole segment).
  O(toggled pairs) numpy work over ``NDBG.toggle_pairs``.
* ``ideals``: every feasible moving set of one restricted DBG, or their number (capped);
  ``TooManyPartitions`` past the cap. O(|S|) per ideal; the count can be exponential in |S|.

``rap.geometry.partitions`` turns moving sets and runs of cells into ``Partition`` objects;
``rap.geometry.sampling`` draws moving sets at random from the same closures and segments.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

from rap.errors import InputError
from rap.geometry.ndbg import NDBG

__all__ = ["TooManyPartitions", "subset_mask", "closure", "changed_cells", "cell_segments",
           "ideals"]


class TooManyPartitions(InputError):
    """Enumerating all partitions would exceed the configured budget."""


def subset_mask(ndbg: NDBG, subset: Iterable[str]) -> tuple[int, list[int]]:
    """(bitmask of the parts of ``subset``, their indices in increasing order); ``InputError``
    naming an id that is not a part of the NDBG's assembly."""
    pos = {p: i for i, p in enumerate(ndbg.ids)}
    m = 0
    for p in subset:
        if p not in pos:
            raise InputError(f"unknown part id {p!r}")
        m |= 1 << pos[p]
    idx = [i for i in range(ndbg.n) if m >> i & 1]
    return m, idx


def closure(start: int, adj, within: int) -> int:
    """The parts of ``within`` reachable from the parts of ``start`` (included) over ``adj``
    (``adj[v]``: the bitmask of v's neighbours)."""
    seen = start
    frontier = start
    while frontier:
        new = 0
        while frontier:
            low = frontier & -frontier
            new |= adj[low.bit_length() - 1]
            frontier ^= low
        new &= within & ~seen
        seen |= new
        frontier = new
    return seen


def changed_cells(ndbg: NDBG, m: int) -> list[int]:
    """Indices k >= 1 of the cells whose DBG restricted to the parts in m differs from k - 1's:
    those with a toggled pair (i, j) of parts both in m. O(toggled pairs) numpy work on integer
    arrays (``NDBG.toggle_pairs``), a few microseconds per thousand pairs."""
    cell, first, second = ndbg.toggle_pairs
    inside = np.unpackbits(np.frombuffer(m.to_bytes((ndbg.n + 7) // 8 or 1, "little"), np.uint8),
                           bitorder="little")[:ndbg.n].astype(bool)
    hit = cell[inside[first] & inside[second]]
    return np.unique(hit[hit > 0]).tolist()


def cell_segments(ndbg: NDBG, m: int) -> tuple[list[int], list[int]]:
    """First and last cell index of each maximal run of cells with one DBG restricted to m."""
    N = len(ndbg.cells)
    first = [0] + changed_cells(ndbg, m)
    last = [(first[s + 1] - 1) if s + 1 < len(first) else N - 1 for s in range(len(first))]
    return first, last


def ideals(idx: list[int], r: list[int], m: int, cap: int, count_only: bool = False):
    """Nonempty proper successor-closed subsets of m (a list; with count_only their number,
    at most cap + 1). Raises ``TooManyPartitions`` past cap when listing."""
    n = max(idx) + 1
    inn = [0] * n
    for v in idx:
        mm = r[v]
        while mm:
            low = mm & -mm
            inn[low.bit_length() - 1] |= 1 << v
            mm ^= low
    reach = [0] * n
    coreach = [0] * n
    for v in idx:
        reach[v] = closure(1 << v, r, m)
        coreach[v] = closure(1 << v, inn, m)
    res: list[int] = []
    found = 0
    stack = [(0, 0)]
    while stack:
        inc, exc = stack.pop()
        und = m & ~(inc | exc)
        if not und:
            if inc and inc != m:
                if count_only:
                    found += 1
                    if found > cap:
                        return found
                    continue
                res.append(inc)
                if len(res) > cap:
                    raise TooManyPartitions(
                        f"more than {cap} feasible moving sets in one cell; use a limit budget")
            continue
        low = und & -und
        v = low.bit_length() - 1
        stack.append((inc, exc | coreach[v]))
        stack.append((inc | reach[v], exc))
    return found if count_only else res
