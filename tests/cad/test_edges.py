"""rap.cad.edges: nodes merged within the tolerance, one geometry per edge, T-junction splits."""

from __future__ import annotations

import math

from rap.cad.edges import EdgeTable, NodeIndex, closest, merge_nodes, split_at_nodes

from .fixtures import GRID, arc


def test_ends_within_the_tolerance_become_one_node_at_their_mean():
    """A chain of points each within 0.01 of the next merges whole (transitively), snapped once;
    a point farther away keeps a node of its own."""
    pts = [(1.0, 1.0), (1.008, 1.0), (1.016, 1.0), (5.0, 5.0), (1.008, 1.0)]
    nodes = merge_nodes(pts, GRID.step_float, GRID)
    assert nodes[0] == nodes[1] == nodes[2] == nodes[4] == (101, 100)  # mean x 1.008
    assert nodes[3] == (500, 500)


def test_two_flattenings_of_one_arc_drawn_both_ways_are_one_edge():
    table = EdgeTable(GRID.step_float)
    a = arc(10, 5, 5, -math.pi / 2, math.pi / 2, 25)
    b = arc(10, 5, 5, math.pi / 2, -math.pi / 2, 31)
    ea, rev_a = table.lookup((1000, 0), (1000, 1000), a)
    eb, rev_b = table.lookup((1000, 1000), (1000, 0), b)
    assert ea == eb and rev_a != rev_b
    straight, _ = table.lookup((1000, 0), (1000, 1000), [(10.0, 0.0), (10.0, 10.0)])
    assert straight != ea  # same nodes, another geometry: another edge
    assert len(table.polys) == 2


def test_an_edge_is_split_at_a_node_on_it():
    index = NodeIndex({(0, 0), (1000, 0), (400, 0), (400, 300)}, GRID)
    pieces = split_at_nodes([(0.0, 0.0), (10.0, 0.0)], (0, 0), (1000, 0), index, GRID.step_float)
    assert [(u, v) for u, v, _ in pieces] == [((0, 0), (400, 0)), ((400, 0), (1000, 0))]
    assert pieces[0][2] == [(0.0, 0.0), (4.0, 0.0)]


def test_closest_point_of_a_segment():
    assert closest((5.0, 3.0), (0.0, 0.0), (10.0, 0.0)) == (3.0, 0.5)
    assert closest((-4.0, 3.0), (0.0, 0.0), (10.0, 0.0)) == (5.0, 0.0)
    assert closest((1.0, 1.0), (0.0, 0.0), (0.0, 0.0)) == (math.hypot(1, 1), 0.0)
