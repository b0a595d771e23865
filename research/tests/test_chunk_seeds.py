"""research.variants.chunks: chunk seeds of sequential tests are deterministic, distinct, never the label's."""

from __future__ import annotations

import pytest

from rap.seeds import derive_seed
from research.variants.chunks import chunk_seed


def test_chunk_seeds_are_deterministic_distinct_and_not_the_operations_own():
    seeds = [derive_seed(11, f"{k:064x}") for k in range(50)]
    got = {(s, i): chunk_seed(s, i) for s in seeds for i in range(4)}
    assert got == {(s, i): chunk_seed(s, i) for s in seeds for i in range(4)}  # deterministic
    assert len(set(got.values())) == len(got)  # distinct over operations and chunks
    assert not set(got.values()) & set(seeds)  # never an operation's (label's) own seed
    assert all(0 <= v < 1 << 63 for v in got.values())
    with pytest.raises(ValueError):
        chunk_seed(seeds[0], -1)
