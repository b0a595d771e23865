"""NDBG sweep: cell order, vertex/arc structure, agreement with per-pair blocking sets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.geometry.exact import angle_key, in_open_arc
from rap.geometry.families.simple import random_tiling
from rap.geometry.contacts import meeting_pairs
from rap.geometry.ndbg import (blocked_at, build_ndbg, cell_at, cell_index,
                               is_feasible_operation, is_free_operation, ndbg_of)

from .fixtures import (CORNER_TOUCH, DECIMALS, FAR_APART, FRAMED, FRAMED_LOOSE, GRID2,
                       L_AND_SQUARE, SINGLE, TWO_SIDE_BY_SIDE, VALID, make, square)

vec = st.tuples(st.integers(-40, 40), st.integers(-40, 40)).filter(lambda v: v != (0, 0))


def _names(ndbg, blocks):
    return {(ndbg.ids[i], ndbg.ids[j]) for i, j in blocks}


def test_grid2_axes_are_vertices():
    nd = build_ndbg(GRID2)
    assert [c.kind for c in nd.cells] == ["vertex", "arc"] * 4
    assert [c.direction for c in nd.cells[::2]] == [(1, 0), (0, 1), (-1, 0), (0, -1)]
    right = _names(nd, nd.cells[0].blocks)
    assert right == {("r0c0", "r0c1"), ("r1c0", "r1c1")}  # sliding past along rows is free
    diag = _names(nd, nd.cells[1].blocks)  # up-right: everything behind is blocked
    assert ("r0c0", "r1c1") in diag and ("r1c1", "r0c0") not in diag
    assert nd.cells[1].unit == pytest.approx((2 ** -0.5, 2 ** -0.5))


def test_single_part_and_no_critical_directions():
    nd = build_ndbg(SINGLE)
    assert len(nd.cells) == 1 and nd.cells[0].kind == "arc" and not nd.cells[0].blocks
    assert cell_index(nd, (3, -7)) == 0


def test_wrap_arc_comes_first_when_angle_zero_is_not_critical():
    nd = build_ndbg(FAR_APART)  # a at x in [0,1], b at [10,11]: critical directions off-axis
    assert nd.criticals[0] != (1, 0)
    first = nd.cells[0]
    assert first.kind == "arc" and first.contains((1, 0))
    assert angle_key(nd.cells[1].direction) < angle_key(nd.cells[2].direction)


@pytest.mark.parametrize("asm", VALID, ids=lambda a: a.name)
def test_cells_are_ccw_and_alternate(asm):
    nd = build_ndbg(asm)
    if len(nd.cells) == 1:
        return
    kinds = [c.kind for c in nd.cells]
    assert all(kinds[k] != kinds[k - 1] for k in range(len(kinds)))
    verts = [c.direction for c in nd.cells if c.kind == "vertex"]
    assert verts == sorted(verts, key=angle_key) == list(nd.criticals)
    for k, c in enumerate(nd.cells):
        assert cell_index(nd, c.direction) == k
        if c.kind == "arc":
            assert in_open_arc(c.direction, c.start, c.end)


def _brute(nd, d):
    return frozenset((i, j) for (i, j), bs in nd.pair_blocking.items() if bs.contains(d))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10 ** 6), st.lists(vec, min_size=5, max_size=5))
def test_sweep_agrees_with_pair_sets(seed, dirs):
    asm = random_tiling(6, np.random.default_rng(seed))
    nd = build_ndbg(asm)
    for d in dirs + list(nd.criticals[:4]):
        assert cell_at(nd, d).blocks == _brute(nd, d)


@pytest.mark.parametrize("asm", [GRID2, L_AND_SQUARE, FRAMED, CORNER_TOUCH, DECIMALS],
                         ids=lambda a: a.name)
def test_every_cell_agrees_with_pair_sets(asm):
    nd = build_ndbg(asm)
    for c in nd.cells:
        assert c.blocks == _brute(nd, c.direction)


def test_framed_core_blocked_everywhere():
    nd = build_ndbg(FRAMED)
    for c in nd.cells:
        assert (1, 0) in c.blocks and (0, 1) in c.blocks


def test_decimals_slide_vertically():
    nd = build_ndbg(DECIMALS)
    assert nd.scale == 10
    assert not cell_at(nd, (0, 1)).blocks  # touching at x = 0.1 and 0.3, sliding is free
    assert _names(nd, cell_at(nd, (1, 0)).blocks) == {("a", "b"), ("a", "c"), ("b", "c")}


def test_feasibility_query():
    nd = build_ndbg(GRID2)
    assert is_feasible_operation(nd, ["r1c1"], ["r0c0", "r0c1", "r1c0"], (1, 1))
    assert not is_feasible_operation(nd, ["r0c0"], ["r1c1", "r0c1", "r1c0"], (1, 1))
    assert is_feasible_operation(nd, ["r1c0", "r1c1"], ["r0c0", "r0c1"], (0.0, 1.0))
    assert not is_feasible_operation(nd, ["r1c0", "r1c1"], ["r0c0", "r0c1"], (0.01, -1.0))
    assert blocked_at(nd, (2, 0)) == nd.cells[0].outs


# a slides along b's bottom edge when it leaves to the right: its sweep grazes b, its goal does not
GRAZE = make("graze", [{"id": "a", "polygon": square(0, 0)}, {"id": "b", "polygon": square(2, 1)}])


@pytest.mark.parametrize("asm,moving,fixed,removal,free", [
    (FAR_APART, "a", "b", (-1, 0), True),  # away from b
    (FAR_APART, "a", "b", (0, 1), True),
    (FAR_APART, "a", "b", (1, 0), False),  # through b
    (FAR_APART, "a", "b", (1, 1), True),  # b's shadow: the open arc from (9, -1) to (9, 1)
    (GRID2, "r1c1", "r0c0,r0c1,r1c0", (1, 1), False),  # touching at the goal
    (TWO_SIDE_BY_SIDE, "a", "b", (-1, 0), False),  # separable, but touching
    (CORNER_TOUCH, "a", "b", (-1, -1), False),  # a common vertex is a touch
    (GRAZE, "a", "b", (1, 0), False),  # an arc's end: the sweep grazes b
    (GRAZE, "a", "b", (1, -1), True),
    (GRAZE, "a", "b", (-1, 0), True),
    (FRAMED_LOOSE, "core", "frame,out", (0, 1), False),  # blocked all around, touching nothing
    (FRAMED_LOOSE, "out", "frame", (1, 0), False),  # out touches the frame
])
def test_free_operation(asm, moving, fixed, removal, free):
    """Free: the moving parts, swept from their place along the removal direction, never meet a
    fixed part, closed sets (exact; vertex and grazing contacts count)."""
    got = is_free_operation(ndbg_of(asm), meeting_pairs(asm), moving.split(","), fixed.split(","),
                            removal)
    assert got is free


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10 ** 6), vec)
def test_free_agrees_with_a_swept_union(seed, d):
    """At directions inside arcs, free agrees with shapely: the swept moving part (its union with
    its far translate's hull, per convex piece) meets no fixed part."""
    from shapely.geometry import MultiPoint, Polygon
    from shapely.ops import unary_union

    rng = np.random.default_rng(seed)
    asm = make("apart", [{"id": f"p{k}", "polygon": square(int(x), int(y), int(s))}
                         for k, (x, y, s) in enumerate(zip(rng.choice(60, 3, replace=False) * 3,
                                                          rng.integers(0, 20, 3),
                                                          rng.integers(1, 3, 3)))])
    nd = ndbg_of(asm)
    if any(c.kind == "vertex" and c.direction == d for c in nd.cells):
        return  # a critical direction: the graze case, tested above
    far = 1000
    a = asm.parts[0]
    pts = [(float(x), float(y)) for x, y in a.outer]
    swept = MultiPoint(pts + [(x + far * d[0], y + far * d[1]) for x, y in pts]).convex_hull
    others = unary_union([Polygon(p.float_outer()) for p in asm.parts[1:]])
    want = not swept.intersects(others)
    assert is_free_operation(nd, meeting_pairs(asm), ["p0"], ["p1", "p2"], d) is want


def test_ndbg_of_is_one_ndbg_an_assembly():
    assert ndbg_of(GRID2) is ndbg_of(GRID2)
    assert ndbg_of(GRID2).criticals == build_ndbg(GRID2).criticals
