"""Partitions: RAP's online choice, all partitions, interlocking."""

from __future__ import annotations

import numpy as np
import pytest

from rap.geometry.exact import in_open_arc
from rap.geometry.moving_sets import TooManyPartitions
from rap.geometry.ndbg import build_ndbg, is_feasible_operation
from rap.geometry.partitions import (_online_choice, all_partitions, interlocked, online_partitions,
                                     single_part_partitions)

from .fixtures import DOVETAIL, FAR_APART, FRAMED, FRAMED_LOOSE, GRID2, GRID3, L_AND_SQUARE, make, square


def test_grid2_online():
    nd = build_ndbg(GRID2)
    ps = online_partitions(nd, nd.ids)
    assert [sorted(p.moving) for p in ps] == [["r1c1"], ["r1c0"], ["r0c0"], ["r0c1"]]
    top_right = ps[0]
    assert (top_right.range_start, top_right.range_end) == ((1, 0), (0, 1))
    assert top_right.direction == (1, 1) and not top_right.start_closed
    op = top_right.operation()
    assert op.direction == pytest.approx((-(2 ** -0.5), -(2 ** -0.5)))
    assert op.exact_direction == (-1, -1) and op.fixed == frozenset(nd.ids) - op.moving


def test_online_ranges_are_feasible_and_strictly_inside():
    for asm in (GRID3, L_AND_SQUARE, FAR_APART, FRAMED_LOOSE):
        nd = build_ndbg(asm)
        for p in online_partitions(nd, nd.ids):
            assert p.contains(p.direction)
            if p.span == "range":
                assert in_open_arc(p.direction, p.range_start, p.range_end)
            assert is_feasible_operation(nd, p.moving, p.fixed, p.direction)


def test_merging_across_angle_zero():
    nd = build_ndbg(FAR_APART)  # a left of b: a is free except in b's shadow cone
    ps = online_partitions(nd, nd.ids)
    # moving {a}: everywhere except the shadow cone, one range wrapping through angle pi
    assert len(ps) == 2
    ranges = {tuple(sorted(p.moving)): p for p in ps}
    a, b = ranges[("a",)], ranges[("b",)]
    assert (a.range_start, a.range_end, a.start_closed) == ((9, 1), (9, -1), True)
    assert a.direction == (-1, 0)
    # b's range wraps around angle 0 and was merged into one partition there
    assert (b.range_start, b.range_end, b.start_closed) == ((9, -1), (9, 1), False)
    assert b.direction == (1, 0) and b.contains((1, 0))


def test_interlocked_fixtures():
    assert interlocked(build_ndbg(DOVETAIL), DOVETAIL.ids)
    assert interlocked(build_ndbg(FRAMED), FRAMED.ids)
    nd = build_ndbg(FRAMED_LOOSE)
    assert not interlocked(nd, nd.ids)
    assert interlocked(nd, ["frame", "core"])
    assert not interlocked(build_ndbg(GRID2), GRID2.ids)


def test_all_partitions_grid2():
    nd = build_ndbg(GRID2)
    ps = all_partitions(nd, nd.ids)
    moving = {p.moving for p in ps}
    assert frozenset({"r0c0", "r0c1"}) in moving  # bottom row down
    assert frozenset({"r0c0", "r1c1"}) not in moving
    keys = [(sorted(p.moving), p.range_start) for p in ps]
    assert len(set(map(repr, keys))) == len(ps)
    for p in ps:
        assert is_feasible_operation(nd, p.moving, p.fixed, p.direction)
    assert len(ps) >= len(online_partitions(nd, nd.ids))


def test_all_partitions_sampling_is_seeded():
    nd = build_ndbg(GRID3)
    full = all_partitions(nd, nd.ids)
    a = all_partitions(nd, nd.ids, limit=5, rng=np.random.default_rng(1))
    b = all_partitions(nd, nd.ids, limit=5, rng=np.random.default_rng(1))
    assert a == b and len(a) == 5 and all(p in full for p in a)
    assert a == sorted(a, key=lambda p: full.index(p))
    with pytest.raises(ValueError):
        all_partitions(nd, nd.ids, limit=5)


def test_moving_set_in_two_disjoint_ranges():
    # b between two walls: it leaves up or down only, two separate vertex ranges
    asm = make("slot", [{"id": "w1", "polygon": square(0, 0)}, {"id": "b", "polygon": square(1, 0)},
                        {"id": "w2", "polygon": square(2, 0)}])
    nd = build_ndbg(asm)
    ps = [p for p in all_partitions(nd, nd.ids) if p.moving == frozenset({"b"})]
    assert sorted(p.range_start for p in ps) == [(0, -1), (0, 1)]
    assert all(p.span == "vertex" for p in ps)


def test_budget():
    asm = make("spread", [{"id": f"p{k}", "polygon": square(3 * k, 0)} for k in range(10)])
    nd = build_ndbg(asm)
    with pytest.raises(TooManyPartitions):
        all_partitions(nd, nd.ids, max_count=100)


def test_sink_component_choice_with_cycles():
    # 0 <-> 1 (a sink pair), 2 -> 0, 3 has no out-edges: sinks {0,1} and {3}; smallest is {0,1}
    out = [0b10, 0b01, 0b01, 0]
    inn = [0b110, 0b01, 0, 0]
    assert _online_choice(out, inn, [0, 1, 2, 3], 0b1111) == 0b11
    # a strongly connected whole has no partition
    assert _online_choice([0b10, 0b01], [0b10, 0b01], [0, 1], 0b11) == 0
    # 0 -> 1 -> 2 -> 1: sink {1, 2} is the only one
    assert _online_choice([0b10, 0b100, 0b10], [0, 0b101, 0b10], [0, 1, 2], 0b111) == 0b110


def _networkx_choice(cell, idx):
    """Independent reference: sink SCC (networkx) holding the smallest index, or None."""
    import networkx as nx

    g = nx.DiGraph()
    g.add_nodes_from(idx)
    g.add_edges_from((i, j) for i, j in cell.blocks if i in idx and j in idx)
    cond = nx.condensation(g)
    sinks = [frozenset(cond.nodes[c]["members"]) for c in cond if cond.out_degree(c) == 0]
    best = min(sinks, key=min)
    return None if len(best) == len(idx) else best


@pytest.mark.parametrize("seed", range(4))
def test_online_matches_networkx_per_cell(seed):
    from rap.geometry.families.simple import random_tiling

    rng = np.random.default_rng(seed)
    asm = random_tiling(12, rng)
    nd = build_ndbg(asm)
    subsets = [list(range(12))] + [sorted(rng.choice(12, size=int(rng.integers(2, 12)),
                                                     replace=False).tolist()) for _ in range(3)]
    for idx in subsets:
        ids = [nd.ids[i] for i in idx]
        ps = online_partitions(nd, ids)
        for c in nd.cells:
            want = _networkx_choice(c, idx)
            got = [p for p in ps if p.contains(c.direction)]
            if want is None:
                assert not got
            else:
                assert len(got) == 1
                assert got[0].moving == frozenset(nd.ids[i] for i in want)


@pytest.mark.parametrize("seed", range(3))
def test_all_partitions_match_brute_force(seed):
    from itertools import combinations

    from rap.geometry.families.simple import random_tiling

    asm = random_tiling(6, np.random.default_rng(seed))
    nd = build_ndbg(asm)
    ps = all_partitions(nd, nd.ids)
    for c in nd.cells:
        blocks = c.blocks
        want = set()
        for r in range(1, 6):
            for mv in combinations(range(6), r):
                if not any((i, j) in blocks for i in mv for j in range(6) if j not in mv):
                    want.add(frozenset(nd.ids[i] for i in mv))
        got = [p.moving for p in ps if p.contains(c.direction)]
        assert len(got) == len(set(got)) and set(got) == want


@pytest.mark.parametrize("seed", range(3))
def test_single_part_partitions_are_all_partitions_moving_one_part(seed):
    """Per cell, the parts that can leave alone (brute force over the cell's blocking pairs),
    for the whole and for a subset; every range holds its cells and nothing else."""
    from rap.geometry.families.simple import random_tiling

    asm = random_tiling(6, np.random.default_rng(seed))
    nd = build_ndbg(asm)
    for subset in (nd.ids, nd.ids[:4]):
        ps = single_part_partitions(nd, subset)
        assert all(len(p.moving) == 1 and p.moving | p.fixed == frozenset(subset) for p in ps)
        idx = [nd.index(x) for x in subset]
        for c in nd.cells:
            want = {nd.ids[i] for i in idx
                    if not any((i, j) in c.blocks for j in idx if j != i)}
            got = [next(iter(p.moving)) for p in ps if p.contains(c.direction)]
            assert len(got) == len(set(got)) and set(got) == want
    assert single_part_partitions(nd, nd.ids[:1]) == []


def test_cell_partition_counts():
    from rap.geometry.partitions import cell_partition_counts

    nd = build_ndbg(GRID2)
    counts = cell_partition_counts(nd, nd.ids)
    ps = all_partitions(nd, nd.ids)
    assert counts == [sum(p.contains(c.direction) for p in ps) for c in nd.cells]
    assert cell_partition_counts(nd, nd.ids, cap=2) == [min(2, c) for c in counts]
    assert cell_partition_counts(build_ndbg(FRAMED), FRAMED.ids) == [0] * len(build_ndbg(FRAMED).cells)
