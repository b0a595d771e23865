"""Single-part mechanisms (rap.sim.mechanisms): tipping and sliding with the other parts fixed,
on contact points given directly (unit normals into the part), and the pre-stressed equilibria
that check_static rejects because of them."""

from __future__ import annotations

import numpy as np
import pytest

from rap.sim.mechanisms import (first_mechanism, mechanism_table, part_mechanisms,
                                single_part_mechanism)
from rap.sim.statics import check_static
from tests.sim.cells import DOWN, WALL, WEDGED

G = np.array([0.0, -1.0])
UP, RIGHT, LEFT = [0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]


def mech(points, normals, centroid, friction=0.5, g=G):
    return single_part_mechanism(np.array(points, float), np.array(normals, float),
                                 np.array(centroid, float), g, friction)


def test_resting_block_has_none():
    # a 2 x 1 block on a floor, centroid between its two support points
    assert mech([[0, 0], [2, 0]], [UP, UP], [1, 0.5]) is None


def test_overhanging_block_tips_about_its_last_support():
    got = mech([[0, 0], [2, 0]], [UP, UP], [2.5, 0.5])
    assert got.kind == "tip" and got.where == (2.0, 0.0)


def test_knife_edge_tips():
    got = mech([[0, 0], [2, 0]], [UP, UP], [2.0, 0.5])
    assert got.kind == "tip"


def test_a_side_neighbour_does_not_hold_an_overhanging_block():
    # support under the left half only, a neighbour on the left: rotating about (1, 0) lifts
    # the left side and opens the side contact (points (0, 0.1) and (0, 0.9), normal +x)
    got = mech([[0.05, 0], [0.95, 0], [0, 0.1], [0, 0.9]], [UP, UP, RIGHT, RIGHT], [1.0, 0.5])
    assert got.kind == "tip"


def test_a_neighbour_on_the_tipping_side_holds_it():
    # the same block tipping clockwise would push into a neighbour on its right
    assert mech([[0.05, 0], [0.95, 0], [2, 0.1], [2, 0.9]], [UP, UP, LEFT, LEFT],
                [1.0, 0.5]) is None


@pytest.mark.parametrize("friction,slides", [(0.3, True), (0.7, False)])
def test_slope(friction, slides):
    n = np.array([-1.0, 2.0]) / np.sqrt(5)  # a slope of tangent 0.5
    got = mech([[0, 0], [2, 1]], [n, n], [1, 1.5], friction)
    assert (got is not None and got.kind == "slide") == slides


def test_wedged_between_walls_falls_whatever_the_friction():
    got = mech([[0, 0], [0, 1], [1, 0], [1, 1]], [RIGHT, RIGHT, LEFT, LEFT], [0.5, 0.5], 10.0)
    assert got.kind == "slide" and got.where == (0.0, -1.0)


def test_no_contact_falls():
    assert mech(np.zeros((0, 2)), np.zeros((0, 2)), [0, 0]).kind == "fall"


def _random_parts(rng, n_parts=12, k=7):
    """Padded tables of parts whose contact points lie on a grid, normals among a few directions
    (so that knife edges, sliding contacts and wedges occur), and a random mask of present ones."""
    units = np.array([UP, RIGHT, LEFT, [0.0, -1.0], [-1.0, 2.0], [1.0, 2.0]])
    units /= np.hypot(units[:, 0], units[:, 1])[:, None]
    points = rng.integers(0, 3, size=(n_parts, k, 2)).astype(float)
    normals = units[rng.integers(0, len(units), size=(n_parts, k))]
    centroids = rng.integers(0, 5, size=(n_parts, 2)) / 2
    return points, normals, centroids, rng.random((n_parts, k)) < 0.5


@pytest.mark.parametrize("g,friction", [(G, 0.5), (G, 0.0), (np.array([0.6, -0.8]), 1.0)])
def test_the_table_answers_every_subset_as_the_part_alone(g, friction):
    """first_mechanism and part_mechanisms on padded tables with points masked out agree with
    single_part_mechanism given only the present points."""
    rng = np.random.default_rng(5)
    kinds = set()
    for _ in range(30):
        points, normals, centroids, valid = _random_parts(rng)
        alone = [single_part_mechanism(points[p][valid[p]], normals[p][valid[p]], centroids[p],
                                       g, friction) for p in range(len(points))]
        assert part_mechanisms(points, normals, valid, centroids, g, friction) == alone
        table = mechanism_table(points, normals, centroids, g, friction)
        rows = rng.permutation(len(points))[:8]
        moving = [i for i, p in enumerate(rows) if alone[p] is not None]
        got = first_mechanism(table, rows, valid[rows])
        assert got == ((moving[0], alone[rows[moving[0]]]) if moving else None)
        kinds |= {m.kind for m in alone if m is not None} | {m is None for m in alone}
    assert {"tip", "slide", "fall", True} <= kinds


def test_check_static_rejects_pre_stressed_equilibria():
    got = check_static(WEDGED, WEDGED.ids, "base", DOWN, friction=10.0)
    assert not got.stable and "'block' would slide" in got.reason
    got = check_static(WALL, ["plate", "c0_b0", "c1_b0", "c1_b1"], "plate", DOWN)
    assert not got.stable and "'c1_b1' would tip over about (19.5, 10)" in got.reason
