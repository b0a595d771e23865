"""docs/EXTENDING.md, "A planning method", followed step by step: a toy planner and its options
class, registered, then planned with through make_planner, the experiment's names, the service's
request parser and the CLI."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import ClassVar

import pytest

from rap.errors import ParameterError
from rap.serve.api import BadRequest, parse_plan_request
from rap.plan.scoring.cache import ScoreCache
from rap.experiment.run import method_planner
from rap.plan.graph import Interlocked, assembly_order
from rap.plan.methods import (METHODS, from_table_name, make_planner, needs_model, register,
                              unregister)
from rap.plan.planners.options import PlannerOptions, option
from rap.plan.planners.base import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus, PlanStep
from rap.plan.scoring.scorer import Scorer
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROW3, memory, six, write
from tests.plan.standins import HashSim


# step 1: the options, as in the doc
@dataclass(frozen=True)
class FirstOptions(PlannerOptions):
    """The toy planner's options."""

    pick: int = option(int, 0, low=0, code="i", code_name="I",
                       help="Method {method}: the candidate taken at every subassembly")

    method: ClassVar[str] = "first"
    needs_model: ClassVar[bool] = False


# step 2: the planner, as in the doc
class FirstPlanner(Planner):
    """Candidate number ``pick`` (or the last) of every subassembly; no scores asked."""

    name = "first"
    options_class = FirstOptions

    def _search(self, problem, scorer, stats):
        choice, todo = {}, [problem.whole] if len(problem.whole) >= 2 else []
        while todo:
            subset = todo.pop()
            candidates = problem.candidates(subset)
            if not candidates:
                raise Interlocked(subset)
            op = candidates[min(self.pick, len(candidates) - 1)]
            choice[subset] = PlanStep.of(op, "first")
            todo += [side for side in (op.moving, op.fixed) if len(side) >= 2]
        return assembly_order(choice, problem.whole)


FirstOptions.planner = FirstPlanner


@pytest.fixture
def first():
    """Step 3, the method registered as in the doc; removed again after the test, so that the
    other tests see the shipped methods only."""
    register(FirstOptions)
    try:
        yield FirstOptions
    finally:
        unregister("first")
    assert "first" not in METHODS


def test_a_planner_built_without_arguments_has_its_declared_defaults():
    assert FirstPlanner().pick == 0 and FirstPlanner(pick=3).pick == 3
    assert FirstPlanner(FirstOptions(pick=2)).pick == 2
    with pytest.raises(ParameterError):
        FirstPlanner(pick=-1)


def test_the_toy_planner_through_make_planner_and_the_experiment_names(first):
    assert METHODS["first"] is first and not needs_model("first")
    problem = PlanningProblem(six("hexagon"), SimParams(trials=10))
    plans = {}
    for pick in (0, 1):
        r = make_planner("first", pick=pick).solve(problem, Scorer(HashSim(), None, ScoreCache()))
        assert r.status is PlanStatus.FOUND and r.method == "first"
        assert check_plan(problem.assembly, r.steps) == []
        assert all(s.source == "first" and s.score is not None for s in r.steps)
        plans[pick] = [s.to_json() for s in r.steps]
    assert plans[0] != plans[1]
    interlocked = PlanningProblem(memory(FRAMED_HOLE), SimParams(trials=10))
    r = make_planner("first").solve(interlocked, Scorer(HashSim(), None, ScoreCache()))
    assert r.status is PlanStatus.INFEASIBLE and set(r.interlocked) == {"frame", "plug"}
    with pytest.raises(ParameterError, match="pick -1: choose an integer >= 0"):
        make_planner("first", pick=-1)
    assert from_table_name("first-i2") == first(pick=2) and first(pick=2).table_name() == "first-i2"
    assert method_planner("first-i1").pick == 1
    with pytest.raises(ParameterError, match="first options are -iI"):
        method_planner("first-x1")


def test_the_service_takes_the_toy_method_and_its_option(first):
    body = {"assembly": ROW3, "method": "first", "options": {"pick": 2}}
    _, method, _, options, _ = parse_plan_request(json.dumps(body).encode())
    assert (method, options) == ("first", {"pick": 2})
    body["options"] = {"pick": -1}
    with pytest.raises(BadRequest, match=r"options.pick -1: must be >= 0") as err:
        parse_plan_request(json.dumps(body).encode())
    assert err.value.status == 400
    body["options"] = {"simulations": 5}
    with pytest.raises(BadRequest, match="options.simulations applies to method search, not "
                                         "'first'"):
        parse_plan_request(json.dumps(body).encode())


def test_the_toy_method_through_the_cli(first, tmp_path, run_cli):
    src, out = write(ROW3, tmp_path / "row3.json"), tmp_path / "plan.json"
    code, stdout, stderr = run_cli("plan", src, "--method", "first", "--trials", "8", "--no-cache",
                                   "--workers", "1", "--out", out)
    assert code == 0, stderr
    doc = json.loads(out.read_text())
    assert doc["method"] == "first" and doc["feasible"] is True and len(doc["steps"]) == 2
    assert "first plan" in stdout
