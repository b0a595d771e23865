"""Plan documents (rap.plan.report.result): a result written as JSON reads back exactly."""

from __future__ import annotations

import json

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
