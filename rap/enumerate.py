"""Every assembly operation of an assembly, deduplicated, with content keys and seeded sampling.

``enumerate_operations(assembly)`` walks every reachable subassembly of the AND/OR graph
(``rap.geometry.andor``) and lists all of its distinct partitions (``mode="all"``: every closed
moving set of every cell of the NDBG; ``mode="online"``: RAP's one-per-cell choice). Operations are
deduplicated by their content key and returned in a canonical order (sorted by key), so the list
does not depend on dictionary or traversal order.

``sample_operations(ops, k, root_seed, geometry_hash)`` keeps the ``k`` operations with the
smallest seeded hash: a seeded subset that is stable (the same for the same seed) and nested (the
sample for ``k`` is a prefix of the sample for ``k + 1``), so growing ``--max-ops-per-assembly`` on
an existing dataset only adds rows.

``label_key`` / ``label_seed`` define a row's identity in the dataset: the operation's content key
(geometry + operation + simulator parameters) combined with the run's root seed, and the
per-operation simulator seed derived from them (``rap.seeds.derive_seed``).

No ray here.
"""

from __future__ import annotations

import hashlib
from typing import Iterable, Sequence

from rap.assembly import Assembly
from rap.operation import Operation
from rap.seeds import derive_seed

__all__ = [
    "MODES",
    "enumerate_operations",
    "reachable_operations",
    "sample_operations",
    "label_key",
    "label_seed",
    "operation_count",
]

MODES = ("all", "online")


def label_key(op: Operation, geometry_hash: str, params_fingerprint: str, root_seed: int) -> str:
    """The dataset key of one labelled operation (hex SHA-256): content key + root seed."""
    base = op.key(geometry_hash, params_fingerprint)
    return hashlib.sha256(f"{base}|root={int(root_seed)}".encode()).hexdigest()


def label_seed(op: Operation, geometry_hash: str, params_fingerprint: str, root_seed: int) -> int:
    """The simulator seed of one operation: ``derive_seed(root_seed, op.key(gh, fp))``."""
    return derive_seed(root_seed, op.key(geometry_hash, params_fingerprint))


def reachable_operations(assembly: Assembly, mode: str = "all") -> Iterable[Operation]:
    """Operations of every reachable composite subassembly of the AND/OR graph, in graph order.

    Raises ``rap.geometry.partitions.TooManyPartitions`` (an ``InputError``) past the geometry
    layer's enumeration budget.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, not {mode!r}")
    from rap.geometry.andor import and_or_graph
    from rap.geometry.ndbg import build_ndbg

    graph = and_or_graph(build_ndbg(assembly), mode=mode)
    for subset in sorted(graph.partitions, key=lambda s: (len(s), sorted(s))):
        for part in graph.partitions[subset]:
            yield part.operation()


def enumerate_operations(assembly: Assembly, mode: str = "all") -> list[Operation]:
    """All distinct operations of ``assembly`` (deduplicated by content key), sorted by key."""
    gh = assembly.geometry_hash
    by_key: dict[str, Operation] = {}
    for op in reachable_operations(assembly, mode):
        by_key.setdefault(op.key(gh), op)
    return [by_key[k] for k in sorted(by_key)]


def sample_operations(ops: Sequence[Operation], k: int | None, root_seed: int,
                      geometry_hash: str) -> list[Operation]:
    """A seeded subset of ``k`` operations (all of them when ``k`` is None or >= len(ops)).

    Ranks operations by ``derive_seed(root_seed, op.key(geometry_hash))`` and keeps the smallest
    ``k``; the result is in canonical (key) order whatever the input order. O(n log n).
    """
    if k is not None and k < 0:
        raise ValueError("k must be >= 0")
    keyed = [(op.key(geometry_hash), op) for op in ops]
    if k is not None and k < len(keyed):
        keyed.sort(key=lambda t: (derive_seed(root_seed, t[0]), t[0]))
        keyed = keyed[:k]
    keyed.sort(key=lambda t: t[0])
    return [op for _, op in keyed]


def operation_count(assembly: Assembly, mode: str = "all") -> int:
    return len(enumerate_operations(assembly, mode))
