"""The search's options as data (``SearchOptions``), with the defaults and the measurements that
chose them. ``rap.plan.search.planner.SearchPlanner()`` is the shipped search. No ray, no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rap.plan.planners.options import PlannerOptions, option

__all__ = ["SearchOptions", "GREEDY_FROM", "IMPROVE", "GREEDY_SHARE", "WINDOW", "BEAM_FROM",
           "SEARCH_SIMULATIONS", "SEARCH_UPPER", "SEARCH_GAP", "DEFAULT_BEAM",
           "DEFAULT_MAX_OPERATIONS", "DEFAULT_CONFIDENCE", "BOUND_ROUND"]

DEFAULT_BEAM = 8
DEFAULT_MAX_OPERATIONS = 20_000
DEFAULT_CONFIDENCE = 0.95
#: operations simulated per round while choosing by bounds (``upper`` > 0), the most raised
#: first: on ten fresh validation assemblies (lookup tables, shipped model) one or two a round
#: reached 0.976 of the optimum with ``upper`` 1 and 200 simulations, the whole optimistic
#: sequence a round 0.951; two keep two simulation workers busy
BOUND_ROUND = 2
# Its defaults (SearchOptions: 200 simulations, upper 0.35, confidence 0.95, no gap): on 12
# held-out assemblies (research/bound_coverage.py --set unseen): 0.997 of the optimum against
# 0.899 for the previous default (no simulations); chosen on the fresh validation set. The
# previous default: --simulations 0 (then upper and gap change nothing). --gap 0.05 tightens the
# plan's bound on the optimum to within 5% (unseen: mean gap 9.0% against 26.5%) for 2.5 times the
# simulations and about 2.2 times the planning time (19.5 s against 8.7 s on the 12 unseen
# assemblies, research/plan_timing.py), so it is asked for, not
# the default (docs/RESULTS.md, "Phase 2" and "Real plans, timed").
SEARCH_SIMULATIONS = 200
SEARCH_UPPER = 0.35
SEARCH_GAP = 0.0
# From GREEDY_FROM parts on, the search starts from simulator-only greedy's plan and spends at most
# IMPROVE times greedy's simulations improving it (docs/PLANNING.md, "Planning at scale"): beyond a
# dozen parts the plan's many steps keep the exact refine from settling within its 200 simulations
# (the 22-brick wall and the 5 x 5 grid stopped by budget, at 4.6 and 3.7 times greedy's time); up
# to a dozen it settles sooner than greedy plans (greedy first there: 1.2-1.7 times the time for
# the same plans, benchmarks/plan_scale.py up to 12 parts).
GREEDY_FROM = 13
IMPROVE = 1.0
#: with a ``time_limit``, greedy's start may simulate for at most this share of it; past it, its
#: levels left are chosen by the model alone (an anytime greedy), and the search improves what is
#: left of the time (benchmarks/time_limit.py: with half, greedy's 12.7 s on grid 49 was cut at a
#: 20 s limit and the model's plan was 0.18 of greedy's R)
GREEDY_SHARE = 0.8
#: beyond the exact budget, the chosen plan's runs of one-part steps are re-ordered WINDOW steps at
#: a time (rap.plan.search.windows; research/window_reorder.py: gains of 1.12-1.25 on greedy's
#: chains at 30-49 parts with 4)
WINDOW = 4
#: from BEAM_FROM parts the search goes to the beam without walking the graph to its budget: on
#: benchmarks/plan_scale.py's 20 assemblies of 30-100 parts (two seeds) every graph had more than
#: DEFAULT_MAX_OPERATIONS operations, and the walk that finds it out took 1-4 s (wall 44: 2.7 s of
#: 18.7); a narrow graph (a stack) is all but exhausted by the beam anyway
BEAM_FROM = 30


@dataclass(frozen=True)
class SearchOptions(PlannerOptions):
    """The best product of the model's scores over every sequence (``SearchPlanner``)."""

    method: ClassVar[str] = "search"
    needs_model: ClassVar[bool] = True
    summary: ClassVar[str] = ("the best product of the model's scores over every sequence, "
                              "dynamic programming or a beam")

    simulations: int = option(int, SEARCH_SIMULATIONS, low=0, code="s", code_name="N",
                              help="Method {method}: simulations to spend while planning (0: "
                                   "none, the model's scores alone)")
    trust: float | None = option(
        float, None, low=0.0, high=1.0, low_open=True, noun="a score", code="t", code_name="P",
        percent=True, default_help="none trusted",
        help="Method {method}: operations predicted at this score or more are not simulated "
             "while planning")
    optimism: float = option(
        float, 0.0, low=0.0, high=1.0, code="o", code_name="P", percent=True,
        help="Method {method} with {simulations}: an operation not simulated counts as p + "
             "OPTIMISM (1 - p) while choosing, so alternatives the model may underrate get "
             "simulated (0: the model as is; 1: the optimum, simulations permitting)")
    upper: float = option(
        float, SEARCH_UPPER, low=0.0, high=1.0, code="u", code_name="U", percent=True,
        help="Method {method} with {simulations}: an operation not simulated counts as p + UPPER "
             "(u - p) while choosing, u its upper bound at {confidence} (the larger of this and "
             "{optimism}'s; 0: off; 1: branch and bound, stopping when no sequence left can "
             "beat the best simulated one)")
    confidence: float = option(
        float, DEFAULT_CONFIDENCE, low=0.0, high=1.0, low_open=True, noun="a probability",
        code="c", code_name="P", percent=True,
        help="Method {method}: the confidence of the bound on the optimum reported with the "
             "plan (each of a sequence's n - 1 steps bounded at 1 - (1 - P) / (n - 1))")
    gap: float = option(
        float, SEARCH_GAP, low=0.0, high=1.0, noun="a fraction", code="g", code_name="G",
        percent=True,
        help="Method {method} with {simulations}: simulate until the best simulated sequence "
             "is within GAP of the bound on the optimum, going on by the bounds after the "
             "choice is settled, or until the budget is spent (0.05: 5%; 0: off, stop when the "
             "choice is settled or the budget spent)")
    time_limit: float = option(
        float, 0.0, low=0.0, code="l", code_name="S", noun="seconds", default_help="none",
        help="Method {method} with {simulations}: stop simulating after S seconds of planning and "
             "return the best plan by what is known then (checked between rounds of "
             "simulations; 0: no limit)")
    greedy_from: int = option(
        int, GREEDY_FROM, low=2, code="f", code_name="N",
        help="Method {method}: from N parts on, start from simulator-only greedy's plan (the "
             "result is never worse than it) and improve it with at most {improve} times "
             "greedy's simulations (beyond the exact budget, the beam always starts from it)")
    improve: float = option(
        float, IMPROVE, low=0.0, code="i", code_name="X", percent=True,
        help="Method {method}: after greedy's start, simulations to spend improving its plan, as "
             "a multiple of greedy's own (at most {simulations})")
    beam_from: int = option(
        int, BEAM_FROM, low=2, code="e", code_name="N",
        help="Method {method}: from N parts on, the beam without walking the graph (the walk to "
             "the exact search's budget takes 1-4 s there and finds every measured graph too "
             "large)")
    window: int = option(
        int, WINDOW, low=0, high=8, code="r", code_name="K",
        help="Method {method}, beyond the exact budget: re-order the chosen plan's one-part steps "
             "K at a time, exactly, with what is left of the simulations (0: off)")
    beam_width: int = option(int, DEFAULT_BEAM, low=1, code="w", code_name="W",
                             help="Method {method}: beam width beyond the exact search's budget")
    bound_round: int = option(
        int, BOUND_ROUND, low=1, cli=False, service=False,
        help="Method {method}: operations simulated a round while choosing by bounds")
    max_operations: int = option(
        int, DEFAULT_MAX_OPERATIONS, low=1, code="b", code_name="OPS", cli=False, service=False,
        help="Method {method}: the exact search's budget of operations; beyond it, the beam")
    alternatives: int = option(
        int, 0, low=0, code="k", code_name="K", cli=False, service=False,
        help="Method {method}: besides its plan, SearchPlanner.search returns up to K other "
             "distinct complete plans it knows, best first by their products of known scores "
             "(exact: the K best trees of the graph; beam: the final beam's sequences; no "
             "simulation; 0: none). The plan is the same whatever K")
