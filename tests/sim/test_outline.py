"""The simulator's simplified shapes (rap.sim.outline): a curved part of many convex pieces seen
through a bounded number of them, within the tolerance of the exact polygon; few pieces stay
exact. The gears are benchmarks/curved_parts.py's (300-420 vertices, an axle hole each)."""

from __future__ import annotations

import importlib.util

import pytest
import shapely
from shapely.geometry import Polygon
from shapely.ops import unary_union

from rap.sim.outline import assembly_outlines, outline, part_tolerance
from rap.sim.params import SimParams
from rap.sim.shapes import assembly_pieces, convex_pieces
from rap.sim.simulator import build_scene
from tests.plan.cases import ROOT, six

_spec = importlib.util.spec_from_file_location("curved_parts",
                                               ROOT / "benchmarks" / "curved_parts.py")
curved = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(curved)

SHEET = curved.gear_sheet("mesh")


def _signed_area(piece) -> float:
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(piece, piece[1:] + piece[:1]))


@pytest.mark.parametrize("pid", ["gear24", "gear16", "gear20", "arm"])
@pytest.mark.parametrize("fraction,cap", [(0.002, 32), (0.002, 48), (0.01, 16)])
def test_a_curved_part_within_the_tolerance_in_a_bounded_number_of_pieces(pid, fraction, cap):
    part = SHEET.part(pid)
    exact = Polygon(part.float_outer(), part.float_holes())
    asked = part_tolerance(part, fraction)
    got = outline(part, asked, cap)
    assert len(convex_pieces(part)) > 16  # a curved part: many exact pieces
    assert 1 <= len(got.pieces) <= cap
    assert got.tolerance == 0 or got.tolerance >= asked  # exact, or doubled from what was asked
    polys = [Polygon(pc) for pc in got.pieces]
    for pc, poly in zip(got.pieces, polys):  # convex, counter-clockwise, of positive area
        assert poly.is_valid and _signed_area(list(pc)) > 0
        assert abs(poly.convex_hull.area - poly.area) <= 1e-9 * poly.area
    union = unary_union(polys)
    assert union.buffer(1e-6 * asked).covers(exact)  # the part is inside its outline
    tol = max(got.tolerance, 1e-9)
    # the Hausdorff distance of the regions is at most tol: the part is inside the union, and the
    # union inside the part grown by tol (a polygonal buffer is inside the true one: conservative)
    assert exact.buffer(tol, quad_segs=32).covers(union)
    band = union.difference(exact)  # what the outline adds: no farther than tol from the part
    assert shapely.get_coordinates(band).size == 0 or max(
        exact.distance(shapely.Point(x, y)) for x, y in shapely.get_coordinates(band)) <= tol
    assert union.area - exact.area <= tol * exact.length + 3.15 * tol * tol * len(part.holes)
    if cap == 48:  # room for every tooth: the tolerance asked was enough
        assert got.tolerance <= asked


def test_parts_of_few_pieces_are_simulated_exactly():
    """Every part of the reference assemblies (at most 11 pieces a part in the whole corpus) keeps
    its exact pieces: the simulator's scores, and every label key, are as they were."""
    for name in ("rectilinear", "pentagons", "hexagon"):
        asm = six(name)
        p = SimParams()
        assert assembly_outlines(asm, p.shape_tolerance, p.shape_pieces) == assembly_pieces(asm)


def test_the_scene_holds_the_simplified_pieces():
    from rap.plan.problem import PlanningProblem

    params = SimParams(trials=2)
    problem = PlanningProblem(SHEET, params)
    op = next(op for op in problem.candidates(frozenset({"gear16", "gear24"})))
    assert not problem.is_free(op)  # the meshing gears touch
    scene = build_scene(SHEET, op, params)
    assert len(scene.moving_shapes[0]) <= params.shape_pieces
    assert len(scene.fixed_shapes[0]) <= params.shape_pieces
