"""Plan documents (rap.plan.report.result): a result written as JSON reads back exactly."""

from __future__ import annotations

import json
import math

import pytest

from rap.plan.scoring.cache import ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.planners.greedy import SimPlanner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult
from rap.plan.scoring.scorer import Scorer
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROW3, memory


@pytest.mark.parametrize("doc", [ROW3, FRAMED_HOLE], ids=["found", "interlocked"])
def test_plan_documents_read_back_exactly(doc):
    problem = PlanningProblem(memory(doc), SimParams(trials=4))
    result = SimPlanner().solve(problem, Scorer(LocalSimulator(), cache=ScoreCache()))
    text = json.dumps(result.to_json())
    back = PlanResult.from_json(json.loads(text))
    assert back.to_json() == result.to_json()
    assert back.status is result.status and back.message == result.message
    assert [s.to_json() for s in back.steps] == [s.to_json() for s in result.steps]
    with pytest.raises(ValueError):
        PlanResult.from_json({"feasible": True})


def test_the_plan_document_carries_its_format_and_older_ones_still_read():
    from rap.plan.report.result import FORMAT, PlanResult, PlanStatus, PlanStep

    step = PlanStep(("a",), ("b",), (0.0, -1.0), "model", 0.9, predicted=0.8)
    doc = PlanResult(PlanStatus.FOUND, "sim", "ab", (step,), 0.9, 1.0).to_json()
    assert list(doc)[0] == "format" and doc["format"] == FORMAT == 3
    assert doc["steps"][0]["insertion"] == [0.0, -1.0]
    assert doc["sequence_success"] is None and doc["steps"][0]["execution"] is None
    # format 2: no sequence, no execution, no predicted; "cnn" where 3 says "model"
    two = {k: v for k, v in doc.items() if k != "sequence_success"} | {"format": 2}
    two["steps"] = [{k: ("cnn" if k == "source" else v) for k, v in doc["steps"][0].items()
                     if k not in ("execution", "predicted")}]
    back = PlanResult.from_json(two)
    assert back.steps[0].source == "model"
    assert back.to_json() == {**doc, "steps": [{**doc["steps"][0], "predicted": None}]}
    old = {k: v for k, v in two.items() if k != "format"}  # format 1: no field, "direction"
    old["steps"] = [{("direction" if k == "insertion" else k): v
                     for k, v in two["steps"][0].items()}]
    back = PlanResult.from_json(old)
    assert back.steps[0].insertion == (0.0, -1.0) and back.to_json() == PlanResult.from_json(
        two).to_json()
    for bad in (4, "2", 0, True):
        with pytest.raises(ValueError, match="this rap-farm reads formats 1 to 3"):
            PlanResult.from_json({**doc, "format": bad})


def test_format_3_carries_sequence_success_and_each_steps_execution():
    from rap.plan.report.execution import SequenceReport, StepExecution
    from rap.plan.report.result import PlanResult, PlanStatus, PlanStep

    ex = StepExecution(reached=400, success_when_reached=0.9, interval=(0.86, 0.93),
                       clearance_mm=0.5, tolerance_mm=0.3, below_budget=True)
    step = PlanStep(("a",), ("b",), (0.0, -1.0), "sim", 0.9, execution=ex)
    seq = SequenceReport(0.62, (0.57, 0.67), 248, 400, {"grasp_across_mm": 0.5}, 7,
                         "sequence success", ({"robustness": 0.9, "rate": 0.62},), 1.5)
    doc = PlanResult(PlanStatus.FOUND, "search", "ab", (step,), 0.9, 1.0, sequence=seq).to_json()
    assert doc["sequence_success"]["rate"] == 0.62 and doc["sequence_success"]["rollouts"] == 400
    assert doc["steps"][0]["execution"]["tolerance_mm"] == 0.3
    json.dumps(doc, allow_nan=False)
    back = PlanResult.from_json(json.loads(json.dumps(doc)))
    assert back.sequence == seq and back.steps[0].execution == ex and back.to_json() == doc


@pytest.mark.parametrize("scores,failures,attempts,written", [
    ((0.5, 0.8), 0.7, 3.25, 3.25),
    ((1.0, 0.0), 1.0, math.inf, None),  # a step that never succeeds: unbounded, null in JSON
    ((0.5, None), None, None, None),  # a score unknown
    ((), 0.0, 0.0, 0.0),
])
def test_expected_failures_and_attempts_beside_r(scores, failures, attempts, written):
    from rap.plan.report.result import PlanResult, PlanStatus, PlanStep

    steps = tuple(PlanStep((f"p{i}",), ("base",), (0.0, -1.0), "sim", r)
                  for i, r in enumerate(scores))
    result = PlanResult(PlanStatus.FOUND, "sim", "x", steps, None, 1.0)
    assert result.expected_failures == (failures if failures is None
                                        else pytest.approx(failures))
    assert result.expected_attempts == attempts
    doc = result.to_json()
    assert doc["expected_attempts"] == written
    assert list(doc).index("expected_attempts") == list(doc).index("expected_failures") + 1
    json.dumps(doc, allow_nan=False)  # strict JSON: no Infinity
