"""Which operations of an assembly a labelling run takes: lazy streams, content keys and seeds.

* ``iter_operations(assembly, mode, directions_per_range, root_seed)``: every operation, lazily:
  the AND/OR graph is walked subassembly by subassembly (``rap.geometry.andor.iter_partitions``)
  and each partition gives its middle direction plus ``directions_per_range - 1`` seeded directions
  strictly inside its merged direction range (``rap.geometry.sampling.directions_in_range``), each
  its own operation with its own content key. ``enumerate_operations`` is the same as a sorted list.
* ``count_operations(..., budget)``: the size of that space, or None past ``budget`` (integer work
  only, no operations built): what makes an uncapped label of a huge space refuse at once.
* ``iter_sampled_operations(assembly, mode, directions_per_range, root_seed)``: distinct operations
  drawn from seeded random disassembly trees (``rap.geometry.sampling``: the distribution is stated
  there), without materialising the space. The stream is a deterministic function of the seed, so
  its first K operations are "the sample of K": growing K only adds operations, and a resumed run
  selects exactly what an uninterrupted one did. It ends when ``patience`` trees in a row bring
  nothing new: the space is exhausted, or what is left of it lies in subassemblies that random
  trees reach rarely (how far the streams of two assemblies go: docs/RESULTS.md).
* ``select_operations(assembly, limit, ...)`` decides: no limit -> every operation (refused with
  ``TooManyOperations`` past the budget); a limit at least the size of the space -> every
  operation; otherwise the first ``limit`` operations of the sampled stream. A selection whose
  stream ends before its total says why (``Selection.shortfall`` -> ``Shortfall``).

``label_key`` / ``label_seed`` define a row's identity in the dataset: the operation's content key
(geometry + operation + simulator parameters) combined with the run's root seed, and the
per-operation simulator seed derived from them (``rap.seeds.derive_seed``). A direction's seed is
derived from the root seed and the partition's content key, so it is the same in every process.

Memory: the sampled stream keeps the keys it has yielded (O(K)); the exhaustive one the set of
subassemblies seen. No ray here.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Callable, Iterator

from rap.assembly import Assembly
from rap.errors import ParameterError
from rap.operation import Operation, subset_key
from rap.seeds import derive_rng, derive_seed

__all__ = [
    "defer_selection",
    "MODES",
    "LABEL_BUDGET",
    "TooManyOperations",
    "Selection",
    "Shortfall",
    "select_operations",
    "iter_operations",
    "iter_sampled_operations",
    "enumerate_operations",
    "count_operations",
    "partition_operations",
    "label_key",
    "label_seed",
]

MODES = ("all", "online")
LABEL_BUDGET = 100_000  # operations an uncapped label may take from one assembly
_PATIENCE = 64  # random trees in a row with nothing new before a sampled stream ends


class TooManyOperations(ParameterError):
    """An assembly's operation space is beyond the budget of an uncapped label: ``limit`` None
    refused. The message names the parameter that caps it (``for_name``: a command's flag)::

        grid.json: more than 100,000 operations (counting stopped there); label a seeded sample
        with limit K
    """

    def __init__(self, where: str, budget: int):
        self.where = where
        super().__init__("limit", None, f"more than {budget:,} operations (counting stopped there)")

    def for_name(self, name: str) -> str:
        return f"{self.where}: {self.reason}; label a seeded sample with {name} K"


def label_key(op: Operation, geometry_hash: str, params_fingerprint: str, root_seed: int) -> str:
    """The dataset key of one labelled operation (hex SHA-256): content key + root seed."""
    base = op.key(geometry_hash, params_fingerprint)
    return hashlib.sha256(f"{base}|root={int(root_seed)}".encode()).hexdigest()


def label_seed(op: Operation, geometry_hash: str, params_fingerprint: str, root_seed: int) -> int:
    """The simulator seed of one operation: ``derive_seed(root_seed, op.key(gh, fp))``."""
    return derive_seed(root_seed, op.key(geometry_hash, params_fingerprint))


def _check_mode(mode: str) -> None:
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, not {mode!r}")


def partition_operations(partition, geometry_hash: str, directions_per_range: int,
                         root_seed: int) -> list[Operation]:
    """The operations of one partition: its middle direction and ``directions_per_range - 1``
    seeded directions strictly inside its range (the seed: root seed + the partition's content)."""
    from rap.geometry.sampling import directions_in_range

    if directions_per_range <= 1 or partition.span == "vertex":
        return [partition.operation()]
    text = "|".join([geometry_hash, subset_key(partition.moving), subset_key(partition.fixed),
                     f"{partition.range_start}", f"{partition.range_end}", partition.span])
    rng = derive_rng(root_seed, hashlib.sha256(text.encode()).hexdigest())
    ops = []
    for i, ((ux, uy), (dx, dy)) in enumerate(directions_in_range(partition, directions_per_range, rng)):
        ops.append(Operation(partition.moving, partition.fixed, (-ux, -uy), (-dx, -dy), i))
    return ops


def iter_operations(assembly: Assembly, mode: str = "all", directions_per_range: int = 1,
                    root_seed: int = 0) -> Iterator[Operation]:
    """Every operation of every reachable composite subassembly, lazily, in graph order.

    Raises ``rap.geometry.moving_sets.TooManyPartitions`` past the geometry layer's
    per-subassembly enumeration budget.
    """
    _check_mode(mode)
    from rap.geometry.andor import iter_partitions
    from rap.geometry.ndbg import build_ndbg

    gh = assembly.geometry_hash
    for _, parts in iter_partitions(build_ndbg(assembly), mode=mode):
        for p in parts:
            yield from partition_operations(p, gh, directions_per_range, root_seed)


def enumerate_operations(assembly: Assembly, mode: str = "all", directions_per_range: int = 1,
                         root_seed: int = 0) -> list[Operation]:
    """All distinct operations of ``assembly`` (deduplicated by content key), sorted by key."""
    gh = assembly.geometry_hash
    by_key: dict[str, Operation] = {}
    for op in iter_operations(assembly, mode, directions_per_range, root_seed):
        by_key.setdefault(op.key(gh), op)
    return [by_key[k] for k in sorted(by_key)]


def count_operations(assembly: Assembly, mode: str = "all", directions_per_range: int = 1,
                     budget: int | None = None) -> int | None:
    """The number of operations ``iter_operations`` yields, or None when it exceeds ``budget``.

    Integer work only (moving sets and cell runs; no directions, no objects); stops as soon as the
    count passes the budget. Cost: O(budget) partitions at most.
    """
    _check_mode(mode)
    from rap.geometry.andor import count_partitions
    from rap.geometry.ndbg import build_ndbg

    return count_partitions(build_ndbg(assembly), mode=mode,
                            directions_per_range=directions_per_range, budget=budget)


def iter_sampled_operations(assembly: Assembly, mode: str = "all", directions_per_range: int = 1,
                            root_seed: int = 0, patience: int = _PATIENCE,
                            ndbg=None) -> Iterator[Operation]:
    """Distinct operations from seeded random disassembly trees (see the module docstring).

    The trees' randomness comes from ``derive_rng(root_seed, "sample|" + geometry hash)``; each
    partition's operations (directions) are yielded together, deduplicated by content key.
    """
    _check_mode(mode)
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.sampling import random_disassembly

    gh = assembly.geometry_hash
    ndbg = ndbg if ndbg is not None else build_ndbg(assembly)
    rng = derive_rng(root_seed, hashlib.sha256(f"sample|{mode}|{gh}".encode()).hexdigest())
    seen_parts: set[tuple] = set()
    seen: set[str] = set()
    idle = 0
    while idle < patience:
        fresh = False
        for p in random_disassembly(ndbg, rng, mode):
            pk = (p.moving, p.fixed, p.range_start, p.range_end, p.span)
            if pk in seen_parts:
                continue
            seen_parts.add(pk)
            for op in partition_operations(p, gh, directions_per_range, root_seed):
                k = op.key(gh)
                if k not in seen:
                    seen.add(k)
                    fresh = True
                    yield op
        idle = 0 if fresh else idle + 1


@dataclass(frozen=True)
class Shortfall:
    """A selection whose stream ended before its total: ``selected`` of ``asked`` operations,
    ``space`` the size of the whole operation space (None: more than ``LABEL_BUDGET``) and why."""

    selected: int
    asked: int
    space: int | None
    reason: str

    def describe(self, no_limit: str = "no limit") -> str:
        """One line; when the space was counted and is larger than asked, how to label all of it:
        ``(no limit labels all 20,796)`` (``no_limit``: the caller's words for it, e.g. a flag)."""
        space = (f"a space of {self.space:,}" if self.space is not None
                 else f"a space of more than {LABEL_BUDGET:,}")
        hint = (f" ({no_limit} labels all {self.space:,})"
                if self.space is not None and self.space > self.asked else "")
        return (f"{self.selected:,} of {self.asked:,} operations asked ({space}): {self.reason}"
                f"{hint}")


@dataclass(frozen=True)
class Selection:
    """The operations of one assembly that a label run takes, as a re-iterable lazy stream.

    ``how`` is ``"all"`` (every operation; ``size`` is their number), ``"sampled"`` (the first
    ``limit`` of the seeded stream; ``size`` is None when the space was not counted to the end) or
    ``"capped"`` (not counted yet, ``defer_selection``: ``total`` is the limit, an upper bound, and
    ``resolved()`` counts and gives the "all" or "sampled" selection). ``total`` is what the run
    expects to label (the stream may end early: ``shortfall``). ``mode``,
    ``directions_per_range`` and ``patience`` are the stream's (to count the space and say why it
    ended).
    """

    assembly: Assembly
    how: str
    total: int
    size: int | None
    stream: Callable[[], Iterator[Operation]]
    mode: str = "all"
    directions_per_range: int = 1
    patience: int = _PATIENCE
    counted_by: Callable[[], "Selection"] | None = None  # "capped": counts and decides

    def resolved(self) -> "Selection":
        """This selection with its space counted: itself unless ``"capped"``, whose count costs
        O(limit) partitions of integer work (and building the assembly's NDBG)."""
        return self if self.counted_by is None else self.counted_by()

    def __iter__(self) -> Iterator[Operation]:
        n = 0
        for op in self.stream():
            if n >= self.total:
                return
            n += 1
            yield op

    def describe(self) -> str:
        if self.how == "all":
            return f"all {self.total}"
        if self.how == "capped":
            return f"at most {self.total} (not counted yet)"
        space = f"of {self.size}" if self.size is not None else "of a larger space"
        return f"a seeded sample of {self.total} {space}"

    def shortfall(self, selected: int, budget: int = LABEL_BUDGET) -> Shortfall | None:
        """None when the stream gave ``total`` operations; else what it could not reach and why.
        A sampled stream ends after ``patience`` random disassembly trees in a row that brought
        nothing new; the space is counted (at most ``budget`` partitions of integer work, about
        1 s for 20,000 operations) to say how much of it there is."""
        if selected >= self.total:
            return None
        if self.how == "capped":
            return self.resolved().shortfall(selected, budget)
        if self.how != "sampled":
            return Shortfall(selected, self.total, self.size,
                             "the space holds fewer distinct operations than were counted")
        # sampled only when the space is larger than the total: what is left of it is there
        space = count_operations(self.assembly, self.mode, self.directions_per_range, budget=budget)
        why = (f"the sampler stopped after {self.patience} random disassembly trees in a row "
               f"brought no new operation; the rest of the space lies in subassemblies its trees "
               f"reach rarely")
        return Shortfall(selected, self.total, space, why)


def select_operations(assembly: Assembly, limit: int | None, root_seed: int, mode: str = "all",
                      directions_per_range: int = 1, budget: int = LABEL_BUDGET) -> Selection:
    """What ``rap-farm label`` takes from ``assembly`` (see the module docstring).

    Raises ``TooManyOperations`` when ``limit`` is None and the space exceeds ``budget``. Counts
    the space with at most ``max(budget, limit)`` partitions of integer work.
    """
    _check_mode(mode)
    if directions_per_range < 1:
        raise ValueError("directions_per_range must be >= 1")
    if limit is not None and limit < 1:
        raise ValueError("limit must be >= 1")
    size = count_operations(assembly, mode, directions_per_range,
                            budget=budget if limit is None else min(limit, budget))
    if limit is None:
        if size is None:
            raise TooManyOperations(assembly.source or assembly.name, budget)
        return Selection(assembly, "all", size, size,
                         lambda: iter_operations(assembly, mode, directions_per_range, root_seed),
                         mode, directions_per_range)
    if size is not None and size <= limit:
        return Selection(assembly, "all", size, size,
                         lambda: iter_operations(assembly, mode, directions_per_range, root_seed),
                         mode, directions_per_range)
    return Selection(assembly, "sampled", limit, None,
                     lambda: iter_sampled_operations(assembly, mode, directions_per_range,
                                                     root_seed),
                     mode, directions_per_range)


def defer_selection(assembly: Assembly, limit: int, root_seed: int, mode: str = "all",
                    directions_per_range: int = 1, budget: int = LABEL_BUDGET) -> Selection:
    """``select_operations(assembly, limit, ...)`` without counting now: a ``"capped"`` selection
    of at most ``limit`` operations, counted where it is first iterated or ``resolved()`` (a
    selection task on a cluster, not the driver). Costs nothing until then."""
    _check_mode(mode)
    if limit < 1 or directions_per_range < 1:
        raise ValueError("limit and directions_per_range must be >= 1")

    def count() -> Selection:
        return select_operations(assembly, limit, root_seed, mode, directions_per_range, budget)

    return Selection(assembly, "capped", limit, None, lambda: iter(count()), mode,
                     directions_per_range, counted_by=count)
