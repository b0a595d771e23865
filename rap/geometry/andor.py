"""The AND/OR graph of recursive disassembly: reachable subassemblies and their partitions.

Starting from the whole assembly, every partition (moving, fixed) of a subassembly yields two
subassemblies, partitioned recursively (memoised per subassembly) until single parts remain.
Mode 'online' uses RAP's one-partition-per-cell choice (``online_partitions``); mode 'all' uses
every feasible partition (``all_partitions``), whose number can be exponential: the search stops
with ``TooManyPartitions`` past ``max_subassemblies`` composite subassemblies or past the
per-subassembly enumeration budget.

``decomposition(ndbg)`` finds one complete disassembly into single parts over the online
partitions (depth first, memoised per subassembly, stopping at the first success): the check that
an assembly is not interlocked anywhere along some sequence, without enumerating the whole graph.

Cost: one partition query per reachable composite subassembly (see ``rap.geometry.partitions``);
``decomposition`` queries only the subassemblies it visits (about n - 1 when the first partition
of every subassembly leads to a full decomposition).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from rap.geometry.ndbg import NDBG
from rap.geometry.moving_sets import TooManyPartitions
from rap.geometry.partitions import (DEFAULT_MAX_COUNT, Partition, all_partitions,
                                     online_partitions, partition_specs, spec_is_vertex)

__all__ = ["AndOrGraph", "and_or_graph", "iter_partitions", "count_partitions", "decomposition",
           "MODES"]

MODES = ("online", "all")


@dataclass(frozen=True)
class AndOrGraph:
    """Reachable subassemblies (single parts included) and the partitions of the composite ones."""

    mode: str
    root: frozenset[str]
    subassemblies: frozenset[frozenset[str]]
    partitions: dict  # frozenset[str] -> tuple[Partition, ...] (composite subassemblies only)
    interlocked: tuple[frozenset[str], ...]

    @property
    def n_subassemblies(self) -> int:
        return len(self.subassemblies)

    @property
    def n_composite(self) -> int:
        return len(self.partitions)

    @property
    def n_operations(self) -> int:
        """Distinct partitions (= assembly operations) over all reachable subassemblies."""
        return sum(len(p) for p in self.partitions.values())


def and_or_graph(ndbg: NDBG, mode: str = "online", root: Iterable[str] | None = None,
                 max_subassemblies: int | None = None,
                 max_count: int = DEFAULT_MAX_COUNT,
                 max_operations: int | None = None) -> AndOrGraph:
    """Enumerate the AND/OR graph from ``root`` (default: the whole assembly), memoised.

    Budgets (each raises ``TooManyPartitions``): ``max_subassemblies`` composite subassemblies,
    ``max_count`` partition incidences per subassembly, ``max_operations`` partitions in all.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    root_set = frozenset(ndbg.ids if root is None else root)
    seen: set[frozenset[str]] = {root_set}
    parts: dict[frozenset[str], tuple[Partition, ...]] = {}
    locked: list[frozenset[str]] = []
    stack = [root_set]
    n_ops = 0
    while stack:
        s = stack.pop()
        if len(s) < 2:
            continue
        if max_subassemblies is not None and len(parts) >= max_subassemblies:
            raise TooManyPartitions(f"more than {max_subassemblies} composite subassemblies")
        ps = tuple(online_partitions(ndbg, s) if mode == "online"
                   else all_partitions(ndbg, s, max_count=max_count))
        parts[s] = ps
        n_ops += len(ps)
        if max_operations is not None and n_ops > max_operations:
            raise TooManyPartitions(f"more than {max_operations} operations")
        if not ps:
            locked.append(s)
        for p in ps:
            for child in (p.moving, p.fixed):
                if child not in seen:
                    seen.add(child)
                    stack.append(child)
    locked.sort(key=lambda x: (len(x), sorted(x)))
    return AndOrGraph(mode, root_set, frozenset(seen), parts, tuple(locked))


def iter_partitions(ndbg: NDBG, mode: str = "online", root: Iterable[str] | None = None,
                    max_count: int = DEFAULT_MAX_COUNT):
    """``(subassembly, partitions)`` of every reachable composite subassembly, lazily, depth first.

    Holds only the set of subassemblies seen and the stack, never the partitions of more than one
    subassembly: a consumer that stops early pays only for what it took. Interlocked
    subassemblies come with an empty tuple.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    root_set = frozenset(ndbg.ids if root is None else root)
    seen: set[frozenset[str]] = {root_set}
    stack = [root_set]
    while stack:
        s = stack.pop()
        if len(s) < 2:
            continue
        ps = tuple(online_partitions(ndbg, s) if mode == "online"
                   else all_partitions(ndbg, s, max_count=max_count))
        yield s, ps
        for p in ps:
            for child in (p.moving, p.fixed):
                if child not in seen:
                    seen.add(child)
                    stack.append(child)


def count_partitions(ndbg: NDBG, mode: str = "all", directions_per_range: int = 1,
                     budget: int | None = None) -> int | None:
    """Operations of the AND/OR graph (a range partition counts ``directions_per_range``, a
    vertex partition 1), or None as soon as the count exceeds ``budget``.

    Mode 'all' works on integer masks only (``partition_specs``); the per-subassembly enumeration
    is capped by the budget too, so the cost is O(budget) partitions however large the space.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    full = (1 << ndbg.n) - 1
    seen = {full}
    stack = [full]
    total = 0
    cap = DEFAULT_MAX_COUNT if budget is None else max(1, budget)
    while stack:
        m = stack.pop()
        if m & (m - 1) == 0:
            continue
        names = ndbg.names(m)
        children = []
        if mode == "online":
            for p in online_partitions(ndbg, names):
                total += 1 if p.span == "vertex" else directions_per_range
                mv = ndbg.mask(p.moving)
                children += [mv, m & ~mv]
        else:
            try:
                specs = partition_specs(ndbg, names, max_count=cap)
            except TooManyPartitions:
                return None
            for spec in specs:
                total += 1 if spec_is_vertex(ndbg, spec) else directions_per_range
                children += [spec[0], m & ~spec[0]]
        if budget is not None and total > budget:
            return None
        for c in children:
            if c not in seen:
                seen.add(c)
                stack.append(c)
    return total

def decomposition(ndbg: NDBG, root: Iterable[str] | None = None) -> dict | None:
    """One full decomposition of ``root`` (default: the whole assembly) into single parts, or None.

    Returns ``{subassembly: Partition}`` for the composite subassemblies of one assembly tree
    (each split by ``online_partitions``), found depth first with memoised failures; None when
    every tree meets an interlocked subassembly. Recursion depth is at most the number of parts.
    """
    root_set = frozenset(ndbg.ids if root is None else root)
    chosen: dict[frozenset[str], Partition | None] = {}

    def solve(s: frozenset[str]) -> bool:
        if len(s) < 2:
            return True
        if s in chosen:
            return chosen[s] is not None
        chosen[s] = None
        for p in online_partitions(ndbg, s):
            if solve(p.moving) and solve(p.fixed):
                chosen[s] = p
                return True
        return False

    if not solve(root_set):
        return None
    tree: dict[frozenset[str], Partition] = {}
    stack = [root_set]
    while stack:
        s = stack.pop()
        if len(s) >= 2:
            p = chosen[s]
            tree[s] = p
            stack += [p.moving, p.fixed]
    return tree
