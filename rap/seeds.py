"""Seeds derived from one root seed and content keys (numpy ``SeedSequence``).

A label depends only on (root seed, operation content key), never on the worker, process or order
that produced it. Library code takes an ``np.random.Generator``; it never touches a global RNG.
``chunk_seed(seed, index)``: the seed of chunk ``index`` of an operation's sequential test
(``rap.sim.sequential``) from the operation's own seed (``label_seed``): a separate simulator run,
never the label's.
"""

from __future__ import annotations

import numpy as np

__all__ = ["derive_seed", "derive_rng", "chunk_seed", "DEFAULT_ROOT_SEED"]

DEFAULT_ROOT_SEED = 20190527


def derive_seed(root_seed: int, key: str) -> int:
    """A 63-bit seed from the root seed and a hex content key. O(len(key))."""
    words = [int(key[i:i + 8], 16) for i in range(0, min(len(key), 32), 8)]
    ss = np.random.SeedSequence([int(root_seed) & 0xFFFFFFFF, (int(root_seed) >> 32) & 0xFFFFFFFF, *words])
    return int(ss.generate_state(2, dtype=np.uint32).astype(np.uint64)[0] << np.uint64(31)
               ^ ss.generate_state(2, dtype=np.uint32).astype(np.uint64)[1]) & ((1 << 63) - 1)


def derive_rng(root_seed: int, key: str) -> np.random.Generator:
    return np.random.default_rng(derive_seed(root_seed, key))


_CHUNK_TAG = 0x5E9C  # keeps chunk seeds apart from any seed spawned from the same words elsewhere


def chunk_seed(seed: int, index: int) -> int:
    """A 63-bit seed for chunk ``index`` (0, 1, ...) of the operation whose simulator seed is
    ``seed``: deterministic, distinct per (seed, index), and never ``seed`` itself. O(1)."""
    if index < 0:
        raise ValueError(f"chunk index {index}: must be non-negative")
    seed = int(seed)
    ss = np.random.SeedSequence([seed & 0xFFFFFFFF, (seed >> 32) & 0xFFFFFFFF, _CHUNK_TAG,
                                 int(index)])
    return int(ss.generate_state(2, dtype=np.uint64)[0]) & ((1 << 63) - 1)
