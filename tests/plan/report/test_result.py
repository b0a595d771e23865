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

    step = PlanStep(("a",), ("b",), (0.0, -1.0), "sim", 0.9)
    doc = PlanResult(PlanStatus.FOUND, "sim", "ab", (step,), 0.9, 1.0).to_json()
    assert list(doc)[0] == "format" and doc["format"] == FORMAT == 2
    assert doc["steps"][0]["insertion"] == [0.0, -1.0]
    old = {k: v for k, v in doc.items() if k != "format"}  # format 1: no field, "direction"
    old["steps"] = [{("direction" if k == "insertion" else k): v
                     for k, v in doc["steps"][0].items()}]
    back = PlanResult.from_json(old)
    assert back.steps[0].insertion == (0.0, -1.0) and back.to_json() == doc
    for bad in (3, "2", 0, True):
        with pytest.raises(ValueError, match="this rap-farm reads formats 1 to 2"):
            PlanResult.from_json({**doc, "format": bad})


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
