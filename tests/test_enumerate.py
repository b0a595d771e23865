"""rap.enumerate: exhaustive lazy streams, bounded counts, seeded sampled streams, selections."""

from __future__ import annotations

import itertools
from fractions import Fraction
from pathlib import Path

import pytest

from rap.io import load_assembly
from rap.enumerate import (LABEL_BUDGET, TooManyOperations, count_operations, enumerate_operations,
                           iter_operations, iter_sampled_operations, label_key, label_seed,
                           select_operations)
from rap.geometry.exact import in_open_arc, primitive
from rap.geometry.families.simple import grid as grid_of
from rap.operation import Operation

ASSEMBLIES = Path(__file__).resolve().parents[1] / "assemblies"


@pytest.fixture(scope="module")
def grid():
    return load_assembly(ASSEMBLIES / "grid.json")


@pytest.fixture(scope="module")
def triangles():
    return load_assembly(ASSEMBLIES / "triangles.json")


def keys(ops, a):
    return [op.key(a.geometry_hash) for op in ops]


def test_keys_and_seeds_depend_on_content_only():
    op = Operation(frozenset({"a"}), frozenset({"b"}), (1.0, 0.0))
    same = Operation(frozenset(op.moving), frozenset(op.fixed), (1.0, 0.0), (Fraction(1), Fraction(0)))
    k = label_key(op, "gh", "fp", 1)
    assert k == label_key(same, "gh", "fp", 1) and len(k) == 64
    assert len({k, label_key(op, "gh2", "fp", 1), label_key(op, "gh", "fp2", 1),
                label_key(op, "gh", "fp", 2)}) == 4
    assert label_seed(op, "gh", "fp", 1) == label_seed(same, "gh", "fp", 1)
    assert label_seed(op, "gh", "fp", 1) != label_seed(op, "gh", "fp", 2)
    assert 0 <= label_seed(op, "gh", "fp", 1) < 2 ** 63


@pytest.fixture(scope="module")
def grid_all(grid):
    return enumerate_operations(grid, "all")


def test_enumeration_is_deduplicated_sorted_and_exhaustive(grid, grid_all):
    from rap.geometry.andor import and_or_graph
    from rap.geometry.ndbg import build_ndbg

    ks = keys(grid_all, grid)
    assert ks == sorted(ks) and len(set(ks)) == len(ks)
    g = and_or_graph(build_ndbg(grid), mode="all")
    assert len(grid_all) == len({(p.moving, p.fixed, p.removal_unit)
                                 for ps in g.partitions.values() for p in ps})
    subs = {op.subassembly for op in grid_all}
    assert frozenset(grid.ids) in subs
    assert subs == set(g.partitions) - set(g.interlocked)  # every composite, non-locked one
    assert enumerate_operations(grid, "all") == grid_all  # deterministic
    assert sorted(keys(iter_operations(grid), grid)) == ks  # the lazy stream is the same set


@pytest.mark.parametrize("n", [1, 3])
@pytest.mark.parametrize("mode", ["all", "online"])
def test_count_matches_the_stream(grid, mode, n):
    assert count_operations(grid, mode, n) == len(list(iter_operations(grid, mode, n, root_seed=4)))
    assert count_operations(grid, mode, n, budget=10) is None


def test_directions_inside_each_range_are_seeded_strictly_inside_and_nested(grid):
    from rap.geometry.andor import iter_partitions
    from rap.geometry.ndbg import build_ndbg
    from rap.enumerate import partition_operations

    gh = grid.geometry_hash
    n_range = 0
    for _, parts in itertools.islice(iter_partitions(build_ndbg(grid), "all"), 20):
        for p in parts:
            three = partition_operations(p, gh, 3, root_seed=9)
            assert three == partition_operations(p, gh, 3, root_seed=9)  # seeded
            assert three[0] == p.operation()  # the middle first (what --directions-per-range 1 takes)
            assert partition_operations(p, gh, 2, root_seed=9) == three[:2]  # nested in N
            if p.span == "vertex":
                assert len(three) == 1
                continue
            n_range += 1
            assert len(three) == 3 and len(set(keys(three, grid))) == 3
            for op in three[1:]:
                d = primitive((-op.exact_direction[0], -op.exact_direction[1]))
                if p.span == "range":
                    assert in_open_arc(d, p.range_start, p.range_end)
                assert abs(op.direction[0] ** 2 + op.direction[1] ** 2 - 1) < 1e-12
            assert partition_operations(p, gh, 3, root_seed=10)[1:] != three[1:]
    assert n_range > 10


def test_sampled_stream_is_seeded_distinct_and_inside_the_space(triangles):
    space = set(keys(enumerate_operations(triangles, "all", 2, root_seed=5), triangles))
    a = list(itertools.islice(iter_sampled_operations(triangles, "all", 2, root_seed=5), 400))
    b = list(itertools.islice(iter_sampled_operations(triangles, "all", 2, root_seed=5), 400))
    assert a == b
    ka = keys(a, triangles)
    assert len(set(ka)) == 400 and set(ka) <= space
    c = list(itertools.islice(iter_sampled_operations(triangles, "all", 2, root_seed=6), 400))
    assert set(keys(c, triangles)) != set(ka)
    assert len({op.subassembly for op in a}) > 50 and {len(op.subassembly) for op in a} == set(range(2, 10))


def test_sampled_stream_ends_when_the_space_is_exhausted(grid):
    space = set(keys(enumerate_operations(grid, "online"), grid))
    got = keys(iter_sampled_operations(grid, "online", root_seed=1, patience=200), grid)
    assert len(got) == len(set(got)) and set(got) <= space
    assert len(got) > 0.9 * len(space)


def test_selection_takes_all_sampled_or_refuses(grid, triangles):
    everything = select_operations(grid, None, 3)
    assert everything.how == "all" and everything.total == len(list(everything)) == 1188
    assert select_operations(grid, 5000, 3).how == "all"  # the space is smaller than the cap
    s = select_operations(triangles, 100, 3)
    assert s.how == "sampled" and s.total == 100
    first = list(s)
    assert len(first) == 100 and first == list(select_operations(triangles, 100, 3))
    assert list(select_operations(triangles, 150, 3))[:100] == first  # growing K only adds
    big = grid_of(6)
    with pytest.raises(TooManyOperations) as err:  # the parameter; `rap-farm label` says its flag
        select_operations(big, None, 3)
    assert err.value.parameter == "limit" and str(err.value) == (
        f"{big.source or big.name}: more than {LABEL_BUDGET:,} operations (counting stopped "
        f"there); label a seeded sample with limit K")
    assert err.value.for_name("--max-ops-per-assembly").endswith("with --max-ops-per-assembly K")
    assert len(list(select_operations(big, 50, 3))) == 50


def test_unknown_mode(grid):
    with pytest.raises(ValueError):
        enumerate_operations(grid, "some")
    with pytest.raises(ValueError):
        select_operations(grid, 3, 1, mode="some")
