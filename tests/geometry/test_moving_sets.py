"""Moving sets on bitmasks: subset masks, closures, the cells where a restricted DBG changes,
ideals (listed, counted, capped)."""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
import pytest

from rap.errors import InputError
from rap.geometry.moving_sets import (TooManyPartitions, cell_segments, changed_cells, closure,
                                      ideals, subset_mask)
from rap.geometry.ndbg import build_ndbg
from rap.io import load_assembly

from .fixtures import GRID3

ROOT = Path(__file__).resolve().parents[2]


def test_subset_mask_and_an_unknown_id():
    nd = build_ndbg(GRID3)
    ids = [nd.ids[4], nd.ids[1]]
    assert subset_mask(nd, ids) == ((1 << 1) | (1 << 4), [1, 4])
    with pytest.raises(InputError, match="unknown part id 'nope'"):
        subset_mask(nd, ["nope"])


def test_closure_follows_the_edges_within_the_mask():
    adj = [0b0010, 0b0100, 0b1000, 0]  # a chain 0 -> 1 -> 2 -> 3
    assert closure(0b0001, adj, 0b1111) == 0b1111
    assert closure(0b0001, adj, 0b0011) == 0b0011
    assert closure(0b0100, adj, 0b1111) == 0b1100


def _ideals_brute_force(idx, r, m):
    out = []
    for k in range(1, len(idx)):
        for sub in combinations(idx, k):
            s = sum(1 << v for v in sub)
            if all(not r[v] & m & ~s for v in sub):
                out.append(s)
    return sorted(out)


def test_ideals_are_the_closed_proper_subsets_and_their_count():
    r = [0b0010, 0b0100, 0, 0b0001]  # 0 -> 1 -> 2, 3 -> 0
    idx, m = [0, 1, 2, 3], 0b1111
    listed = ideals(idx, r, m, cap=100)
    assert sorted(listed) == _ideals_brute_force(idx, r, m) == [0b0100, 0b0110, 0b0111]
    assert ideals(idx, r, m, cap=100, count_only=True) == 3
    assert ideals(idx, r, m, cap=1, count_only=True) == 2  # at most cap + 1
    with pytest.raises(TooManyPartitions):
        ideals(idx, r, m, cap=2)


def _changed_cells_reference(ndbg, m):
    """The per-cell loop that ``changed_cells`` replaced by numpy (kept here as the oracle)."""
    out = []
    for k, (src, rows) in enumerate(ndbg.toggle_rows):
        if k and src & m and any(jm & m and m >> i & 1 for i, jm in rows):
            out.append(k)
    return out


@pytest.mark.parametrize("name", ["grid", "hexagon", "rectilinear", "pentagons"])
def test_changed_cells_equal_the_per_cell_loop(name):
    ndbg = build_ndbg(load_assembly(ROOT / "assemblies" / f"{name}.json"))
    rng = np.random.default_rng(5)
    full = (1 << ndbg.n) - 1
    masks = [full] + [int(rng.integers(1, full + 1)) for _ in range(200)]
    for m in masks:
        assert changed_cells(ndbg, m) == _changed_cells_reference(ndbg, m)


def test_cell_segments_cover_the_cells_in_order():
    nd = build_ndbg(GRID3)
    m, _ = subset_mask(nd, nd.ids)
    first, last = cell_segments(nd, m)
    assert first[0] == 0 and last[-1] == len(nd.cells) - 1
    assert all(f <= lst for f, lst in zip(first, last))
    assert all(nxt == lst + 1 for lst, nxt in zip(last, first[1:]))
    assert first[1:] == changed_cells(nd, m)
