"""Seeded random partitions of the AND/OR graph without enumerating it, and directions in a range.

The operation space of an assembly (every feasible partition of every reachable subassembly) grows
exponentially with the number of parts, so a sample of it cannot be drawn from a list.
``random_partition(ndbg, subset, rng)`` draws one feasible partition of a subassembly S in time
polynomial in |S| and the number of NDBG cells; ``random_disassembly(ndbg, rng)`` draws a whole
random disassembly tree from the full assembly down to single parts and yields its partitions.

Distribution of ``random_partition`` (mode ``"all"``):

1. a direction segment: uniform among the segments of S (the maximal runs of NDBG cells on which the
   DBG restricted to S is constant), rejecting segments whose restricted DBG is strongly connected
   (no feasible partition there);
2. a moving set: the out-closure (the parts that must move with it) of a uniform random part whose
   closure is a proper subset of S; then, with probability 1/2 each time, its union with the
   closure of a further uniform random part outside it, as long as the union stays proper;
3. the range: the maximal run of cells around that segment in which the moving set stays closed,
   exactly as ``all_partitions`` merges it, so every sampled partition is one of the exhaustive
   ones (same moving set, same range, same middle direction).

Mode ``"online"``: uniform among ``online_partitions(ndbg, S)`` (RAP's one-per-cell choice).

A tree starts at the whole assembly and splits every composite subassembly it reaches, depth first;
a subassembly with no feasible partition (interlocked) ends its branch. A tree yields n - 1
partitions when no branch is interlocked. Partitions near the root recur across trees, so
deduplicating consumers see them once and move deeper into the space as they go on.

``directions_in_range(partition, n, rng)``: the partition's middle direction, then n - 1 seeded
directions uniform in angle strictly inside its open range (vertex partitions have one direction).

Cost per partition: O(cells) big-int operations to find the segments of S, O(|S|^2) for the
closures of a segment, O(run length x |S|) for the range. Memory: O(|S|) besides the NDBG.
"""

from __future__ import annotations

import math
from typing import Iterable, Iterator

import numpy as np

from rap.geometry.exact import IVec, exact_direction, in_open_arc
from rap.geometry.ndbg import NDBG
from rap.geometry.moving_sets import cell_segments, closure
from rap.geometry.partitions import Partition, online_partitions, range_partition

__all__ = ["SAMPLING_MODES", "random_partition", "random_disassembly", "directions_in_range"]

SAMPLING_MODES = ("all", "online")


def _mask(ndbg: NDBG, subset: Iterable[str] | None) -> int:
    if subset is None:
        return (1 << ndbg.n) - 1
    return ndbg.mask(subset)


def _bits(m: int) -> list[int]:
    out = []
    while m:
        low = m & -m
        out.append(low.bit_length() - 1)
        m ^= low
    return out


def _closed(outs, members: list[int], m: int, moving: int) -> bool:
    """No part of ``moving`` is blocked by a part of ``m`` outside it, in this cell's DBG."""
    rest = m & ~moving
    return all(not outs[v] & rest for v in members)


def _random_spec(ndbg: NDBG, m: int, rng: np.random.Generator):
    """One (moving mask, first cell, last cell, whole) of S = m, drawn as the module says."""
    idx = _bits(m)
    cells = ndbg.cells
    first, last = cell_segments(ndbg, m)
    n_seg = len(first)
    r = [0] * ndbg.n
    for s in rng.permutation(n_seg):
        s = int(s)
        outs = cells[first[s]].outs
        for v in idx:
            r[v] = outs[v] & m
        moving = 0
        for i in rng.permutation(len(idx)):
            c = closure(1 << idx[int(i)], r, m)
            if c != m:
                moving = c
                break
        if not moving:
            continue  # strongly connected here: no feasible partition in this segment
        while rng.random() < 0.5:
            rest = [v for v in idx if not moving >> v & 1]
            grown = moving | closure(1 << rest[int(rng.integers(len(rest)))], r, m)
            if grown == m:
                break
            moving = grown
        members = _bits(moving)
        lo = hi = s
        steps = 0
        while steps < n_seg - 1 and _closed(cells[first[(lo - 1) % n_seg]].outs, members, m, moving):
            lo = (lo - 1) % n_seg
            steps += 1
        if steps == n_seg - 1:
            return moving, 0, len(cells) - 1, True
        while _closed(cells[first[(hi + 1) % n_seg]].outs, members, m, moving):
            hi = (hi + 1) % n_seg
        return moving, first[lo], last[hi], False
    return None


def random_partition(ndbg: NDBG, subset: Iterable[str] | None, rng: np.random.Generator,
                     mode: str = "all") -> Partition | None:
    """A random feasible partition of ``subset`` (default: every part); None when it is
    interlocked or has fewer than two parts. See the module docstring for the distribution."""
    if mode not in SAMPLING_MODES:
        raise ValueError(f"mode must be one of {SAMPLING_MODES}, not {mode!r}")
    m = _mask(ndbg, subset)
    return _random_partition(ndbg, m, rng, mode)


def _random_partition(ndbg: NDBG, m: int, rng: np.random.Generator, mode: str) -> Partition | None:
    if m & (m - 1) == 0:
        return None
    if mode == "online":
        parts = online_partitions(ndbg, ndbg.names(m))
        return parts[int(rng.integers(len(parts)))] if parts else None
    spec = _random_spec(ndbg, m, rng)
    if spec is None:
        return None
    moving, kf, kl, whole = spec
    return range_partition(ndbg, moving, m, kf, kl, whole)


def random_disassembly(ndbg: NDBG, rng: np.random.Generator, mode: str = "all",
                       root: Iterable[str] | None = None) -> Iterator[Partition]:
    """The partitions of one random disassembly tree of ``root`` (default: the whole assembly),
    depth first; an interlocked subassembly ends its branch."""
    if mode not in SAMPLING_MODES:
        raise ValueError(f"mode must be one of {SAMPLING_MODES}, not {mode!r}")
    stack = [_mask(ndbg, root)]
    while stack:
        m = stack.pop()
        p = _random_partition(ndbg, m, rng, mode)
        if p is None:
            continue
        yield p
        moving = ndbg.mask(p.moving)
        stack.append(moving)
        stack.append(m & ~moving)


def _angle(d) -> float:
    a = math.atan2(float(d[1]), float(d[0]))
    return a + 2 * math.pi if a < 0 else a


def directions_in_range(partition: Partition, n: int, rng: np.random.Generator,
                        max_tries: int = 64) -> list[tuple[tuple[float, float], IVec]]:
    """``(unit vector, exact primitive direction)`` removal directions of ``partition``: its middle
    first, then up to ``n - 1`` seeded ones uniform in angle strictly inside its open range.

    A vertex partition has its one direction. Every exact direction is checked to lie strictly
    inside the open range (``in_open_arc``); a draw that rounds onto a bound is drawn again.
    """
    out = [(partition.removal_unit, partition.direction)]
    if n <= 1 or partition.span == "vertex":
        return out
    if partition.span == "circle":
        a0, width = 0.0, 2 * math.pi
    else:
        s, e = partition.range_start, partition.range_end
        a0 = _angle(s)
        width = (_angle(e) - a0) % (2 * math.pi) or 2 * math.pi
    seen = {partition.direction}
    tries = 0
    while len(out) < n and tries < max_tries * n:
        tries += 1
        a = a0 + float(rng.uniform(0.0, 1.0)) * width
        u = (math.cos(a), math.sin(a))
        d = exact_direction(u)
        if d in seen:
            continue
        if partition.span == "range" and not in_open_arc(d, partition.range_start,
                                                         partition.range_end):
            continue
        seen.add(d)
        out.append((u, d))
    return out
