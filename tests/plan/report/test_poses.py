"""Robot-ready steps (rap.plan.report.poses): poses checked by hand and against the geometry, the
plan's annotation, plan documents old and new, and assembly units."""

from __future__ import annotations

import json

import pytest
from shapely.affinity import translate
from shapely.geometry import Polygon

from rap.assembly import assembly_to_json
from rap.errors import InputError
from rap.operation import Operation
from rap.plan.scoring.cache import ScoreCache
from rap.plan.report.poses import CSV_COLUMNS, annotate_plan, centroid, plan_rows, robot_move
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
from rap.stats import clopper_pearson, successes_of
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROW3, memory

STACK = {"name": "stack", "units": "mm", "parts": [
    {"id": "base", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
    {"id": "top", "polygon": [[0, 10], [10, 10], [10, 20], [0, 20]]}]}


def _polygon(asm, ids, pose=(0.0, 0.0)):
    from shapely.ops import unary_union

    return translate(unary_union([Polygon(asm.part(i).float_outer(), asm.part(i).float_holes())
                                  for i in ids]), *pose)


def test_the_start_is_the_simulators_and_clears_the_fixed_part():
    asm = memory(STACK)
    op = Operation(frozenset({"top"}), frozenset({"base"}), (0.0, -1.0))
    move = robot_move(asm, op, start_gap=0.1)
    # by hand: the whole stack is 20 tall, so the clearance is 2; the top starts 2 above its place
    assert move.clearance == pytest.approx(2.0) and move.travel == pytest.approx(2.0)
    assert move.start == pytest.approx((0.0, 2.0)) and move.goal == (0.0, 0.0)
    assert move.approach == pytest.approx((0.0, 4.0)) and move.approach_distance == 2.0
    assert move.centroid_goal == (5.0, 15.0)
    assert move.to_json()["centroid"] == {"start": [5.0, 17.0], "approach": [5.0, 19.0],
                                          "goal": [5.0, 15.0]}
    from rap.sim.placement import start_offset

    assert move.start == pytest.approx(start_offset(asm, op, SimParams(start_gap=0.1)))
    fixed = _polygon(asm, ["base"])
    assert _polygon(asm, ["top"], move.start).distance(fixed) == pytest.approx(2.0)
    assert robot_move(asm, op, 0.1, approach_distance=5.0).approach == pytest.approx((0.0, 7.0))


@pytest.mark.parametrize("direction", [(1.0, 0.0), (0.6, -0.8), (-0.8, -0.6)])
def test_every_pose_along_the_approach_and_insertion_is_collision_free_until_the_goal(direction):
    asm = memory({"name": "apart", "parts": [
        {"id": "a", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
        {"id": "b", "polygon": [[30, 0], [40, 0], [40, 10], [30, 10]]}]})
    op = Operation(frozenset({"b"}), frozenset({"a"}), direction)
    move = robot_move(asm, op, 0.1)
    assert move.travel == pytest.approx((move.start[0] ** 2 + move.start[1] ** 2) ** 0.5)
    fixed = _polygon(asm, ["a"])
    for t in (0.0, 0.5, 1.0):  # approach -> start: free; start is at least the clearance away
        pose = tuple(a + t * (s - a) for a, s in zip(move.approach, move.start))
        assert _polygon(asm, ["b"], pose).distance(fixed) >= move.clearance - 1e-9


def test_centroid_of_a_part_with_a_hole_is_exact():
    asm = memory(FRAMED_HOLE)
    assert centroid(asm, ["frame"]) == (15.0, 15.0)
    assert centroid(asm, ["frame", "plug"]) == (15.0, 15.0)
    assert centroid(asm, ["side"]) == (35.0, 15.0)


def _solved(doc, trials=4):
    problem = PlanningProblem(memory(doc), SimParams(trials=trials))
    return SimPlanner().solve(problem, Scorer(LocalSimulator(), cache=ScoreCache())), problem


def test_a_found_plan_carries_units_trials_intervals_reasons_and_moves():
    doc = dict(ROW3, units="mm")
    result, problem = _solved(doc)
    assert result.units == "mm" and result.trials == 4 and result.confidence_level == 0.95
    for s in result.steps:
        assert s.insertion == s.direction
        assert s.score_interval == clopper_pearson(successes_of(s.score, 4), 4)
        assert s.reason and s.robot is not None
        assert s.robot == robot_move(problem.assembly, s.to_operation(), problem.params.start_gap)
    lo, hi = result.robustness_interval
    assert lo <= result.robustness <= hi
    rows = plan_rows(result)
    assert [list(r) for r in rows] == [list(CSV_COLUMNS)] * len(result.steps)
    assert rows[0]["units"] == "mm" and rows[0]["step"] == 1
    assert rows[0]["start_x"] == result.steps[0].robot.start[0]


def test_an_interlocked_result_gets_units_but_no_steps():
    result, _ = _solved(FRAMED_HOLE)
    assert result.status is PlanStatus.INFEASIBLE and result.steps == ()
    assert result.units == "unit" and annotate_plan(result, _solved(ROW3)[1]).units == "unit"


def test_documents_read_back_exactly_and_old_ones_with_direction_are_read():
    result, _ = _solved(ROW3)
    doc = json.loads(json.dumps(result.to_json()))
    assert doc["steps"][0]["insertion"] == list(result.steps[0].direction)
    assert "direction" not in doc["steps"][0]
    assert PlanResult.from_json(doc).to_json() == doc
    old = {"assembly": "row3", "method": "sim", "feasible": True, "robustness": 0.5,
           "steps": [{"moving": ["a"], "fixed": ["b"], "direction": [1.0, 0.0], "score": 0.5,
                      "source": "sim", "confidence": None}], "seconds": 1.0}
    back = PlanResult.from_json(old)
    assert back.steps[0] == PlanStep(("a",), ("b",), (1.0, 0.0), "sim", 0.5)
    assert back.units == "unit" and back.robustness_interval is None and back.trials is None


def test_units_are_read_written_and_not_part_of_the_geometry():
    with_mm, plain = memory(dict(ROW3, units="mm")), memory(ROW3)
    assert with_mm.units == "mm" and plain.units == "unit"
    assert with_mm.geometry_hash == plain.geometry_hash and with_mm == plain
    assert assembly_to_json(with_mm)["units"] == "mm" and "units" not in assembly_to_json(plain)
    for bad in ("", "milli metres", 3, "x" * 17):
        with pytest.raises(InputError, match="'units'"):
            memory(dict(ROW3, units=bad))


@pytest.mark.parametrize("units", ["mm", "in"])
def test_an_imported_drawing_states_its_unit_and_the_assembly_file_keeps_it(tmp_path, units):
    from rap.assembly_reader import read_assembly_json
    from rap.cad.importer import ImportOptions, import_drawing
    from rap.commands.import_drawing import write_assembly_json

    from tests.cad.fixtures import MM, dxf_square

    got = import_drawing(dxf_square(tmp_path, MM, side=25.4), ImportOptions(units=units))
    assert got.assembly.units == units
    path = write_assembly_json(got.assembly, tmp_path / "square.json")
    assert json.loads(path.read_text())["units"] == units
    assert read_assembly_json(path).units == units


def test_tidy_reads_float_noise_as_zero():
    from rap.plan.report.poses import tidy

    assert tidy(6.123233995736766e-17) == 0.0 and str(tidy(-1e-17)) == "0.0"
    assert tidy(-0.7071067811865475) == -0.707106781187 and tidy(12.000000000000004) == 12.0
