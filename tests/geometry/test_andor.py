"""AND/OR graph enumeration in both modes."""

from __future__ import annotations

import pytest

from rap.geometry.andor import and_or_graph
from rap.geometry.ndbg import build_ndbg
from rap.geometry.moving_sets import TooManyPartitions

from .fixtures import DOVETAIL, FRAMED_LOOSE, GRID2, SINGLE, TWO_SIDE_BY_SIDE


def test_two_parts():
    g = and_or_graph(build_ndbg(TWO_SIDE_BY_SIDE), "online")
    assert g.subassemblies == {frozenset({"a", "b"}), frozenset({"a"}), frozenset({"b"})}
    assert g.n_composite == 1 and not g.interlocked


def test_grid2_modes():
    nd = build_ndbg(GRID2)
    online, every = and_or_graph(nd, "online"), and_or_graph(nd, "all")
    assert online.subassemblies <= every.subassemblies
    assert online.n_operations <= every.n_operations
    # every nonempty subset of a 2x2 grid is reachable (diagonal pairs by removing the others)
    assert every.n_subassemblies == 15
    for s, ps in every.partitions.items():
        assert all(p.moving | p.fixed == s for p in ps)


def test_interlocked_found():
    g = and_or_graph(build_ndbg(FRAMED_LOOSE), "all")
    assert frozenset({"frame", "core"}) in g.interlocked
    assert and_or_graph(build_ndbg(DOVETAIL)).interlocked == (frozenset({"mortise", "tenon"}),)


def test_single_part_and_budget():
    assert and_or_graph(build_ndbg(SINGLE)).n_subassemblies == 1
    with pytest.raises(TooManyPartitions):
        and_or_graph(build_ndbg(GRID2), "all", max_subassemblies=2)
    with pytest.raises(ValueError):
        and_or_graph(build_ndbg(GRID2), "sometimes")


def test_decomposition():
    from rap.geometry.andor import decomposition

    from .fixtures import FRAMED, GRID3

    assert decomposition(build_ndbg(DOVETAIL)) is None
    assert decomposition(build_ndbg(FRAMED)) is None
    assert decomposition(build_ndbg(SINGLE)) == {}
    tree = decomposition(build_ndbg(GRID3))
    whole = frozenset(GRID3.ids)
    assert len(tree) == len(GRID3) - 1 and whole in tree  # a binary tree over the 9 parts
    for s, p in tree.items():
        assert p.moving | p.fixed == s and not p.moving & p.fixed
        for child in (p.moving, p.fixed):
            assert len(child) == 1 or child in tree
    # a subassembly that comes apart inside an interlocked whole
    assert decomposition(build_ndbg(FRAMED_LOOSE), root=["core", "frame"]) is None
