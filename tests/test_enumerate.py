"""rap.enumerate: exhaustive deduplicated operations, content keys, seeded nested sampling."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from rap.assembly import load_assembly
from rap.enumerate import (enumerate_operations, label_key, label_seed, sample_operations)
from rap.operation import Operation

ASSEMBLIES = Path(__file__).resolve().parents[1] / "assemblies"


def toy_ops(n: int) -> list[Operation]:
    ids = [f"p{i}" for i in range(n + 1)]
    return [Operation(frozenset({ids[i]}), frozenset(ids[:i] + ids[i + 1:]), (1.0, 0.0))
            for i in range(n)]


@pytest.fixture(scope="module")
def grid():
    return load_assembly(ASSEMBLIES / "grid.json")


def test_keys_and_seeds_depend_on_content_only():
    op = toy_ops(1)[0]
    same = Operation(frozenset(op.moving), frozenset(op.fixed), (1.0, 0.0), (Fraction(1), Fraction(0)))
    k = label_key(op, "gh", "fp", 1)
    assert k == label_key(same, "gh", "fp", 1) and len(k) == 64
    assert len({k, label_key(op, "gh2", "fp", 1), label_key(op, "gh", "fp2", 1),
                label_key(op, "gh", "fp", 2)}) == 4
    assert label_seed(op, "gh", "fp", 1) == label_seed(same, "gh", "fp", 1)
    assert label_seed(op, "gh", "fp", 1) != label_seed(op, "gh", "fp", 2)
    assert 0 <= label_seed(op, "gh", "fp", 1) < 2 ** 63


@settings(max_examples=30, deadline=None)
@given(n=st.integers(0, 40), k=st.integers(0, 45), seed=st.integers(0, 2 ** 40))
def test_sample_is_seeded_nested_and_canonical(n, k, seed):
    ops = toy_ops(n)
    a = sample_operations(ops, k, seed, "gh")
    assert a == sample_operations(list(reversed(ops)), k, seed, "gh")  # order of input irrelevant
    assert len(a) == min(k, n)
    assert a == sorted(a, key=lambda op: op.key("gh"))
    bigger = sample_operations(ops, k + 3, seed, "gh")
    assert set(a) <= set(bigger)  # growing K only adds operations
    assert sample_operations(ops, None, seed, "gh") == sorted(ops, key=lambda op: op.key("gh"))


def test_sample_depends_on_seed():
    ops = toy_ops(40)
    assert {frozenset(sample_operations(ops, 5, s, "gh")) for s in range(6)}.__len__() > 1


@pytest.fixture(scope="module")
def grid_all(grid):
    pytest.importorskip("rap.geometry.andor")
    return enumerate_operations(grid, "all")


def test_enumeration_is_deduplicated_sorted_and_exhaustive(grid, grid_all):
    from rap.geometry.andor import and_or_graph
    from rap.geometry.ndbg import build_ndbg

    keys = [op.key(grid.geometry_hash) for op in grid_all]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)
    g = and_or_graph(build_ndbg(grid), mode="all")
    assert len(grid_all) == len({(p.moving, p.fixed, p.removal_unit)
                                 for ps in g.partitions.values() for p in ps})
    subs = {op.subassembly for op in grid_all}
    assert frozenset(grid.ids) in subs
    assert subs == set(g.partitions) - set(g.interlocked)  # every composite, non-locked one
    assert enumerate_operations(grid, "all") == grid_all  # deterministic


def test_online_is_a_smaller_choice(grid, grid_all):
    online = enumerate_operations(grid, "online")
    assert 0 < len(online) <= len(grid_all)
    assert {op.subassembly for op in online} <= {op.subassembly for op in grid_all} | {
        op.subassembly for op in online}


def test_unknown_mode(grid):
    with pytest.raises(ValueError):
        enumerate_operations(grid, "some")
