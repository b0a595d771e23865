"""The planning methods by name: the one place that knows every planner class.

``make_planner(name)`` is what the CLI, the planning service and the experiment call; keeping it
apart from the planner classes lets ``search`` build on ``planners`` without an import cycle.
"""

from __future__ import annotations

from rap.errors import InputError
from rap.plan.planners import (HIGH_PROBABILITY, OptimalPlanner, Planner, RandomPlanner,
                               RapPlanner, SimPlanner)
from rap.plan.search import DEFAULT_BEAM, SearchPlanner

__all__ = ["METHODS", "DEFAULT_METHOD", "make_planner", "RAP_HIGH_PROBABILITY",
           "RAP_FALLBACK_OPTIMISM", "PAPER_RAP"]

METHODS = ("rap", "sim", "optimal", "random", "search")
# What `plan` and the service use when no method is named: on 14 assemblies held out from the
# models' training, search was more robust than every RAP variant and than simulator-only greedy,
# at about RAP's planning time (docs/RESULTS.md, "Planning on held-out assemblies").
DEFAULT_METHOD = "search"
# RAP's defaults: a candidate is taken without simulation at P(high) >= 0.9, and the fallback
# simulates best first with optimism 0.4. Chosen on ten fresh assemblies no model was trained on
# (scripts/rap_validation.py --set fresh): 0.047 more robust than the paper's rule (P(high) >= 0.5,
# every candidate simulated) for 9% more simulations; on the twelve unseen test assemblies within
# 0.006 of simulator-only greedy (the paper's rule: 0.046 below it). docs/RESULTS.md, "RAP's
# decision rule".
RAP_HIGH_PROBABILITY = 0.9
RAP_FALLBACK_OPTIMISM = 0.4
PAPER_RAP = {"high_probability": HIGH_PROBABILITY, "fallback_optimism": 1.0}  # the paper's rule


def make_planner(method: str, *, samples: int = 50, fallback_k: int | None = None,
                 beam_width: int | None = None, simulations: int | None = None,
                 trust: float | None = None, high_probability: float | None = None,
                 optimism: float | None = None,
                 fallback_optimism: float | None = None) -> Planner:
    """The planner named ``method`` (one of ``METHODS``); ``fallback_k`` (None: all),
    ``high_probability`` (None: ``RAP_HIGH_PROBABILITY``) and ``fallback_optimism`` (None:
    ``RAP_FALLBACK_OPTIMISM``; ``PAPER_RAP`` gives the paper's rule) for RAP;
    ``beam_width``, ``simulations``, ``trust`` and ``optimism`` for search (None: its
    defaults)."""
    if method == "rap":
        return RapPlanner(fallback_k=fallback_k,
                          high_probability=RAP_HIGH_PROBABILITY if high_probability is None
                          else high_probability,
                          fallback_optimism=RAP_FALLBACK_OPTIMISM if fallback_optimism is None
                          else fallback_optimism)
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
