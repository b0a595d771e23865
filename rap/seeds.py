"""Seeds derived from one root seed and content keys (numpy ``SeedSequence``).

A label depends only on (root seed, operation content key), never on the worker, process or order
that produced it. Library code takes an ``np.random.Generator``; it never touches a global RNG.
"""

from __future__ import annotations

import numpy as np

__all__ = ["derive_seed", "derive_rng", "DEFAULT_ROOT_SEED"]

DEFAULT_ROOT_SEED = 20190527


def derive_seed(root_seed: int, key: str) -> int:
    """A 63-bit seed from the root seed and a hex content key. O(len(key))."""
    words = [int(key[i:i + 8], 16) for i in range(0, min(len(key), 32), 8)]
    ss = np.random.SeedSequence([int(root_seed) & 0xFFFFFFFF, (int(root_seed) >> 32) & 0xFFFFFFFF, *words])
    return int(ss.generate_state(2, dtype=np.uint32).astype(np.uint64)[0] << np.uint64(31)
               ^ ss.generate_state(2, dtype=np.uint32).astype(np.uint64)[1]) & ((1 << 63) - 1)


def derive_rng(root_seed: int, key: str) -> np.random.Generator:
    return np.random.default_rng(derive_seed(root_seed, key))
