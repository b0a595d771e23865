"""The planning methods: each one's options, planner and needs, in one place; the registry.

A method is one frozen options dataclass (``rap.plan.planners.options.PlannerOptions``) registered here:
its options with their types, defaults, ranges and help, its name in experiment tables, whether it
needs a model, and ``build()``, its planner. Everything that takes a method reads this registry
(``METHODS``, name -> options class, in the order of ``--method``'s choices):

* ``make_planner(name, **options)``: the CLI, the planning service and the experiment plan with it;
* ``rap-farm plan`` makes its flags of the options, the service accepts them in a request's
  ``options`` (``rap.service.api``), and both ask ``needs_model``;
* the experiment names planners ``rap-k2-p90``, ``search-s200-o10`` (``from_table_name``).

Adding a method is one options class with ``@register`` (docs/EXTENDING.md). Keeping the registry
apart from the planner classes lets ``search`` build on ``planners`` without an import cycle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rap.errors import ParameterError
from rap.plan.planners.options import Option, PlannerOptions, option
from rap.plan.planners.base import (HIGH_PROBABILITY, OptimalPlanner, Planner, RandomPlanner,
                               RapPlanner, SimPlanner)
from rap.plan.search.planner import (DEFAULT_BEAM, DEFAULT_CONFIDENCE, DEFAULT_MAX_OPERATIONS,
                             SearchPlanner)

__all__ = ["METHODS", "DEFAULT_METHOD", "make_planner", "register", "unregister",
           "method_options", "needs_model", "check_options", "from_table_name", "option_named",
           "service_options", "RapOptions", "SimOptions", "OptimalOptions", "RandomOptions",
           "SearchOptions", "RAP_HIGH_PROBABILITY", "RAP_FALLBACK_OPTIMISM", "PAPER_RAP",
           "SEARCH_SIMULATIONS", "SEARCH_UPPER", "SEARCH_GAP"]

#: name -> options class, in registration order (``--method``'s choices, the service's enum)
METHODS: dict[str, type[PlannerOptions]] = {}
# What `plan` and the service use when no method is named: on 14 assemblies held out from the
# models' training, search was more robust than every RAP variant and than simulator-only greedy,
# at about RAP's planning time (docs/RESULTS.md, "Planning on held-out assemblies").
# Its defaults (SearchOptions: 200 simulations, upper 0.35, confidence 0.95, no gap): on 12
# held-out assemblies (research/bound_coverage.py --set unseen): 0.997 of the optimum against
# 0.899 for the previous default (no simulations); chosen on the fresh validation set. The
# previous default: --simulations 0 (then upper and gap change nothing). --gap 0.05 tightens the
# plan's bound on the optimum to within 5% (unseen: mean gap 9.0% against 26.5%) for 2.5 times the
# simulations and 2-7 times the planning time (research/plan_timing.py), so it is asked for, not
# the default (docs/RESULTS.md, "Phase 2" and "Real plans, timed").
DEFAULT_METHOD = "search"
SEARCH_SIMULATIONS = 200
SEARCH_UPPER = 0.35
SEARCH_GAP = 0.0
# RAP's defaults: a candidate is taken without simulation at P(high) >= 0.9, and the fallback
# simulates best first with optimism 0.4. Chosen on ten fresh assemblies no model was trained on
# (research/rap_validation.py --set fresh): 0.047 more robust than the paper's rule (P(high) >= 0.5,
# every candidate simulated) for 9% more simulations; on the twelve unseen test assemblies within
# 0.006 of simulator-only greedy (the paper's rule: 0.046 below it). docs/RESULTS.md, "RAP's
# decision rule".
RAP_HIGH_PROBABILITY = 0.9
RAP_FALLBACK_OPTIMISM = 0.4
PAPER_RAP = {"high_probability": HIGH_PROBABILITY, "fallback_optimism": 1.0}  # the paper's rule


def register(options: type[PlannerOptions]) -> type[PlannerOptions]:
    """Make ``options.method`` a planning method (a class decorator). ``ValueError`` for a name
    that is empty, holds ``-`` (experiment names use it) or is taken."""
    name = options.method
    if not name or "-" in name or name in METHODS:
        raise ValueError(f"method name {name!r}: empty, with '-', or registered already")
    METHODS[name] = options
    return options


def unregister(name: str) -> None:
    """Remove the method ``name`` (tests that register a method of their own)."""
    del METHODS[name]


@register
@dataclass(frozen=True)
class RapOptions(PlannerOptions):
    """RAP, the paper's Algorithm 1 with the CNN (``RapPlanner``)."""

    method: ClassVar[str] = "rap"
    needs_model: ClassVar[bool] = True
    summary: ClassVar[str] = "the paper's greedy planner"
    presets: ClassVar[dict] = {"paper": PAPER_RAP}
    planner: ClassVar[type] = RapPlanner

    fallback_k: int | None = option(
        int, None, low=1, code="k", code_name="K",
        help="Method {method}: when no candidate is predicted high, simulate at most the K most "
             "likely", default_help="every candidate, until one is good enough")
    high_probability: float = option(
        float, RAP_HIGH_PROBABILITY, low=0.0, high=1.0, low_open=True, noun="a probability",
        code="p", code_name="P", percent=True, default_help="the paper: 0.5",
        help="Method {method}: a candidate is taken without simulation at P(high) >= this")
    fallback_optimism: float = option(
        float, RAP_FALLBACK_OPTIMISM, low=0.0, high=1.0, code="o", code_name="U", percent=True,
        help="Method {method}: the fallback simulates candidates best first until the best "
             "simulated score exceeds the next one's p + U (1 - p), p its expected score (1: all "
             "at once, the paper's rule with {high_probability} 0.5)")


@register
@dataclass(frozen=True)
class SimOptions(PlannerOptions):
    """Simulator-only greedy: every candidate simulated, the best taken (``SimPlanner``)."""

    method: ClassVar[str] = "sim"
    planner: ClassVar[type] = SimPlanner


@register
@dataclass(frozen=True)
class OptimalOptions(PlannerOptions):
    """The most robust sequence by dynamic programming over the simulator's scores."""

    method: ClassVar[str] = "optimal"
    planner: ClassVar[type] = OptimalPlanner


@register
@dataclass(frozen=True)
class RandomOptions(PlannerOptions):
    """Random sequences, the sample closest to their mean robustness (``RandomPlanner``)."""

    method: ClassVar[str] = "random"
    planner: ClassVar[type] = RandomPlanner

    samples: int = option(int, 50, low=1, service=False,
                          help="Random sequences (method {method})")


@register
@dataclass(frozen=True)
class SearchOptions(PlannerOptions):
    """The best product of the model's scores over every sequence (``SearchPlanner``)."""

    method: ClassVar[str] = "search"
    needs_model: ClassVar[bool] = True
    planner: ClassVar[type] = SearchPlanner
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
    beam_width: int = option(int, DEFAULT_BEAM, low=1, code="w", code_name="W",
                             help="Method {method}: beam width beyond the exact search's budget")
    max_operations: int = option(
        int, DEFAULT_MAX_OPERATIONS, low=1, code="b", code_name="OPS", cli=False, service=False,
        help="Method {method}: the exact search's budget of operations; beyond it, the beam")


def method_options(method: str) -> type[PlannerOptions]:
    """The options class of ``method``; ``ParameterError`` (parameter ``method``) if unknown."""
    try:
        return METHODS[method]
    except (KeyError, TypeError):
        raise ParameterError("method", method, f"choose one of {', '.join(METHODS)}") from None


def needs_model(name: str) -> bool:
    """Whether the method (or experiment method name, ``rap-k2``) scores with a model."""
    return method_options(name.split("-", 1)[0]).needs_model


def option_named(name: str) -> tuple[str, Option]:
    """(the first method that declares option ``name``, its ``Option``); ``KeyError`` if none."""
    for method, options in METHODS.items():
        for opt in options.declared():
            if opt.name == name:
                return method, opt
    raise KeyError(name)


def check_options(**given) -> None:
    """Check every given option (None: not given) against each method that declares it, whatever
    the method planned with (a command validates all its flags at once); ``ParameterError`` for a
    bad value or a name no method declares."""
    for name, value in given.items():
        if value is None:
            continue
        declared = [o for options in METHODS.values() for o in options.declared()
                    if o.name == name]
        if not declared:
            raise ParameterError(name, value, "no planning method has this option")
        for opt in declared:
            opt.check(value)


def make_planner(method: str, **options) -> Planner:
    """The planner of ``method`` with ``options`` (keyword per option; None, and the options of
    other methods, leave the default: a command passes all it has). ``ParameterError`` for an
    unknown method or a bad value; e.g. ``make_planner("rap", fallback_k=2)``,
    ``make_planner("rap", **PAPER_RAP)`` (the paper's rule)."""
    options_class = method_options(method)
    check_options(**options)
    return options_class.of(**options).build()


def from_table_name(name: str, **base) -> PlannerOptions:
    """The options an experiment method name stands for: a method (``sim``), with option codes
    (``rap-k2-p90``, ``search-s200-o10``) or a preset (``rap-paper``); ``base`` sets options
    the name does not (e.g. ``samples``). ``ParameterError`` (parameter ``method``) otherwise."""
    head = name.split("-", 1)[0] if isinstance(name, str) else name
    if head not in METHODS:
        syntax = "; ".join(o.table_syntax() for o in METHODS.values()
                           if any(x.code for x in o.declared()) or o.presets)
        raise ParameterError("method", name, f"choose one of {', '.join(METHODS)} ({syntax})")
    return METHODS[head].from_table_name(name, **base)


def service_options() -> dict[str, tuple[Option, tuple[str, ...]]]:
    """The options the planning service accepts: name -> (its ``Option`` where first declared,
    the methods declaring it); the default method's first, then in registration order."""
    out: dict[str, tuple[Option, tuple[str, ...]]] = {}
    order = [DEFAULT_METHOD] + [m for m in METHODS if m != DEFAULT_METHOD]
    for method in order:
        for opt in METHODS[method].declared() if method in METHODS else ():
            if opt.service:
                first, methods = out.get(opt.name, (opt, ()))
                out[opt.name] = (first, methods + (method,))
    return out
