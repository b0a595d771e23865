"""A plan request's time budget (``POST /plan``'s ``budget_s``), without ray or fastapi.

A request's budget counts from its arrival: ``budget_s`` seconds, the service's
``request_budget_s`` (120 s) unless the request names its own, at most ``plan_budget_s`` (600 s;
``rap.serve.api.ServeConfig``). For a method with a ``time_limit`` (search, the default) it is an
anytime budget: the search is given what is left of it, less ``eval_share`` (25%) for the plan's
evaluation (simulating the returned plan's steps), its bound and the answer, as its
``time_limit``, and answers the best plan found by then (status found, with its bound;
``stats["stopped"] == "time"``); a request's own smaller ``options.time_limit`` wins. Its hard
time budget is the answer's deadline, the budget and ``answer_grace_s`` (past it the answer is a
503): the search needs its first choice to have a plan (on the largest assemblies simulator-only
greedy's plan starts the beam), and its plan's bound, computed after the evaluation, must not meet
an earlier one. The methods without a time limit (sim, rap, optimal, random) keep the hard budget
at ``budget_s``: past it they answer ``"feasible": null``, "budget spent". Every method keeps
``max_simulations`` too.
"""

from __future__ import annotations

import time
from decimal import Decimal

from rap.plan.methods import METHODS
from rap.plan.scoring.scorer import Budget

__all__ = ["read_budget_s", "anytime_limits", "request_limits"]


def read_budget_s(raw, default_s: float, max_s: float) -> float:
    """A request's ``budget_s`` (None: ``default_s``): seconds in (0, ``max_s``], else
    ``ValueError`` with ``(status, one line)``: 400, or 413 past the service's cap."""
    if raw is None:
        return float(min(default_s, max_s))
    if isinstance(raw, bool) or not isinstance(raw, (int, Decimal)) or not raw > 0:
        raise ValueError(400, f"budget_s {raw!r}: must be a positive number of seconds")
    if raw > Decimal(str(max_s)):
        raise ValueError(413, f"budget_s {raw}: this service allows at most {max_s:g} s per "
                              f"request")
    return float(raw)


def anytime_limits(method: str, options: dict, left_s: float, eval_share: float,
                   grace_s: float) -> tuple[dict, float]:
    """(the planner's options, its hard time budget in seconds) for ``left_s`` seconds left of a
    request's budget (module doc): a method with a ``time_limit`` gets ``left_s`` less
    ``eval_share`` of it, or its own when smaller (its 0, "no limit", is the budget's), and the
    hard budget ``left_s + grace_s``; the others their options unchanged and ``left_s``."""
    if not any(o.name == "time_limit" for o in METHODS[method].declared()):
        return options, left_s
    limit = max(left_s * (1.0 - eval_share), 1e-3)  # 0 would mean no limit
    own = options.get("time_limit") or 0.0
    return {**options, "time_limit": min(own, limit) if own > 0 else limit}, left_s + grace_s


def request_limits(body, arrived: float, config) -> tuple[dict, Budget]:
    """(planner options, scorer ``Budget``) of a ``rap.serve.api.PlanBody`` that arrived at
    ``arrived`` (``time.monotonic()``), under ``config`` (``ServeConfig``), now."""
    left = max(body.budget_s - (time.monotonic() - arrived), 1e-3)
    options, hard = anytime_limits(body.method, body.options, left, config.eval_share,
                                   config.answer_grace_s)
    return options, Budget(max_simulations=config.max_simulations, max_seconds=hard)
