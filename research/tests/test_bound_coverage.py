"""research/bound_coverage.py: setting names stand for the planners they name."""

from __future__ import annotations

import pytest

from rap.model.calibration import ScoreBounds
from rap.plan.planners.greedy import SimPlanner
from rap.plan.search.planner import SearchPlanner

from research.bound_coverage import planner_of


@pytest.mark.parametrize("name, expected", [
    ("old", dict(simulations=0, upper=0.0, optimism=0.0, gap=None, trust=None)),
    ("s200-o10", dict(simulations=200, upper=0.0, optimism=0.1, gap=None)),
    ("b40-c95", dict(simulations=40, upper=1.0, confidence=0.95, gap=None, optimism=0.0)),
    ("b200-c95-g5-u35", dict(simulations=200, upper=0.35, confidence=0.95, gap=0.05)),
    ("b80-c90-t97-u50-o10", dict(simulations=80, confidence=0.9, trust=0.97, upper=0.5,
                                 optimism=0.1)),
])
def test_setting_names_build_their_search(name, expected):
    bounds = ScoreBounds.trivial()
    planner = planner_of(name, bounds)
    assert isinstance(planner, SearchPlanner) and planner.bounds is bounds
    for key, value in expected.items():
        assert getattr(planner, key) == value, key


def test_sim_and_bad_names():
    assert isinstance(planner_of("sim", None), SimPlanner)
    with pytest.raises(ValueError):
        planner_of("b40-x95", None)
