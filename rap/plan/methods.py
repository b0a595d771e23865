"""The planning methods' registry: name -> options class, and what reads it.

A method is one frozen options dataclass (``rap.plan.planners.options.PlannerOptions``) beside its
planner (``rap.plan.planners.greedy``, ``optimal``, ``random_sequences``, ``rap.plan.search``):
its options with their types, defaults, ranges and help, its name in experiment tables, whether it
needs a model, and ``build()``, its planner. Everything that takes a method reads this registry
(``METHODS``, name -> options class, in the order of ``--method``'s choices):

* ``make_planner(name, **options)``: the front door ``rap.plan.plan`` plans with it (so do the
  CLI, the planning service and the experiment, through the door);
* ``rap-farm plan`` makes its flags of the options, the service accepts them in a request's
  ``options`` (``rap.serve.api``), and both ask ``needs_model``;
* the experiment names planners ``rap-k2-p90``, ``search-s200-o10`` (``from_table_name``).

Adding a method is one options class and planner, registered with ``register``
(docs/EXTENDING.md).
"""

from __future__ import annotations

from rap.errors import ParameterError
from rap.plan.planners.base import Planner
from rap.plan.planners.greedy import (PAPER_RAP, RAP_FALLBACK_OPTIMISM, RAP_HIGH_PROBABILITY,
                                      RapOptions, SimOptions)
from rap.plan.planners.optimal import OptimalOptions
from rap.plan.planners.options import Option, PlannerOptions
from rap.plan.planners.random_sequences import RandomOptions
from rap.plan.search.options import SEARCH_GAP, SEARCH_SIMULATIONS, SEARCH_UPPER, SearchOptions
from rap.plan.search.planner import SearchPlanner

__all__ = ["METHODS", "DEFAULT_METHOD", "make_planner", "register", "unregister",
           "method_options", "needs_model", "check_options", "from_table_name", "option_named",
           "service_options", "RapOptions", "SimOptions", "OptimalOptions", "RandomOptions",
           "SearchOptions", "RAP_HIGH_PROBABILITY", "RAP_FALLBACK_OPTIMISM", "PAPER_RAP",
           "SEARCH_SIMULATIONS", "SEARCH_UPPER", "SEARCH_GAP"]

#: name -> options class, in registration order (``--method``'s choices, the service's enum)
METHODS: dict[str, type[PlannerOptions]] = {}
# What `plan` and the service use when no method is named: on 14 assemblies held out from the
# models' training, search was more robust than every RAP variant and than simulator-only greedy,
# at about RAP's planning time (docs/RESULTS.md). Its defaults: rap.plan.search.options.
DEFAULT_METHOD = "search"
assert SearchOptions.planner is SearchPlanner  # the search module binds its options


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


for _options in (RapOptions, SimOptions, OptimalOptions, RandomOptions, SearchOptions):
    register(_options)


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
