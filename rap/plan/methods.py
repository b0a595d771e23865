"""The planning methods by name: the one place that knows every planner class.

``make_planner(name)`` is what the CLI, the planning service and the experiment call; keeping it
apart from the planner classes lets ``search`` build on ``planners`` without an import cycle.
"""

from __future__ import annotations

from rap.errors import InputError
from rap.plan.planners import (HIGH_PROBABILITY, OptimalPlanner, Planner, RandomPlanner,
                               RapPlanner, SimPlanner)
from rap.plan.search import DEFAULT_BEAM, SearchPlanner

__all__ = ["METHODS", "DEFAULT_METHOD", "make_planner"]

METHODS = ("rap", "sim", "optimal", "random", "search")
# What `plan` and the service use when no method is named: on 14 assemblies held out from the
# models' training, search was more robust than every RAP variant and than simulator-only greedy,
# at about RAP's planning time (docs/RESULTS.md, "Planning on held-out assemblies").
DEFAULT_METHOD = "search"


def make_planner(method: str, *, samples: int = 50, fallback_k: int | None = None,
                 beam_width: int | None = None, simulations: int | None = None,
                 trust: float | None = None, high_probability: float | None = None,
                 optimism: float | None = None) -> Planner:
    """The planner named ``method`` (one of ``METHODS``); ``fallback_k`` (None: all) and
    ``high_probability`` (None: ``HIGH_PROBABILITY``, the paper's class decision) for RAP;
    ``beam_width``, ``simulations``, ``trust`` and ``optimism`` for search (None: its
    defaults)."""
    if method == "rap":
        return RapPlanner(fallback_k=fallback_k,
                          high_probability=HIGH_PROBABILITY if high_probability is None
                          else high_probability)
    if method == "search":
        return SearchPlanner(beam_width=beam_width or DEFAULT_BEAM,
                             simulations=simulations or 0, trust=trust,
                             optimism=optimism or 0.0)
    if method == "sim":
        return SimPlanner()
    if method == "optimal":
        return OptimalPlanner()
    if method == "random":
        return RandomPlanner(samples)
    raise InputError(f"--method {method!r}: choose one of {', '.join(METHODS)}")
