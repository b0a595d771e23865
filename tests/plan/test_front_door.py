"""rap.plan.plan, the front door: its docstring's example runs (a doctest, in CI), and the CLI,
the service and the experiment reach the planners through it."""

from __future__ import annotations

import ast
import doctest
from pathlib import Path

import pytest

import rap.plan
from rap.plan import plan
from rap.plan.report.result import PlanStatus
from rap.sim.params import SimParams

from tests.plan.cases import ROOT, ROW3, memory
from tests.plan.standins import HashSim


def test_the_docstring_example_runs(monkeypatch):
    monkeypatch.chdir(ROOT)
    failed, tried = doctest.testmod(rap.plan, optionflags=doctest.ELLIPSIS, report=True)
    assert tried >= 4 and failed == 0


def test_the_door_plans_an_assembly_a_problem_or_with_a_planner():
    params = SimParams(trials=10)
    a = plan(memory(ROW3), "sim", params=params, simulator=HashSim())
    assert a.status is PlanStatus.FOUND and len(a.steps) == 2
    from rap.plan.planners.greedy import SimPlanner
    from rap.plan.problem import PlanningProblem

    b = plan(PlanningProblem(memory(ROW3), params), SimPlanner(), simulator=HashSim())
    assert [s.to_json() for s in a.steps] == [s.to_json() for s in b.steps]


def test_a_missing_model_is_one_line():
    from rap.errors import InputError

    with pytest.raises(InputError, match="no such checkpoint file"):
        plan(memory(ROW3), "rap", model="missing.pt", simulator=HashSim())


@pytest.mark.parametrize("caller", ["rap/commands/plan.py", "rap/serve/planning.py",
                                    "rap/experiment/run.py"])
def test_the_pipeline_is_assembled_only_at_the_door(caller):
    """The callers plan through ``rap.plan.plan``; none of them calls a planner's ``solve``."""
    tree = ast.parse((ROOT / caller).read_text())
    doors = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module == "rap.plan"
             and any(a.name == "plan" for a in n.names)]
    solves = [n for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr == "solve"]
    assert doors and not solves, caller
