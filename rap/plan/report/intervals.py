"""How sure a plan's scores are: confidence intervals of step scores and of R from their trials.

A step's score is ``successes / trials`` of the simulator's trials (``SimParams.trials``), so
``successes = round(score * trials)``. Two intervals, both at ``LEVEL`` (95 %) by default:

* **a step**: the Clopper-Pearson ("exact") interval of a binomial proportion: ``[lo, hi]`` with
  ``P(X >= k | lo) = alpha / 2`` and ``P(X <= k | hi) = alpha / 2`` (``lo = 0`` when ``k = 0``,
  ``hi = 1`` when ``k = n``). Its coverage is at least the level for every true success rate,
  unlike Wilson's, which dips below it for some rates: a plan's user gets a guarantee, not an
  average.
* **R**, the product of the steps' success rates: the Bonferroni product. Each of the ``m`` steps
  gets its Clopper-Pearson interval at level ``1 - alpha / m``; R's interval is
  ``[prod lo_i, prod hi_i]``. Every step's interval covers its rate with probability at least
  ``1 - alpha / m``, so all of them do with probability at least ``1 - alpha`` (Bonferroni:
  the steps' trials are independent or not), and then the product lies between the products
  (every factor is in [0, 1], the product is monotone in each). Conservative: real coverage is
  usually higher than the level, and the interval wider than a posterior's.

``tests/plan/report/test_intervals.py`` checks both coverages by simulation on known rates with a
seeded generator.

Floats only (statistics, not geometry). The bounds are found by bisection on the binomial tail
(60 halvings: below 1e-15), each tail a sum of ``trials + 1`` terms in log space: O(60 trials)
per bound, about 0.1 ms for 100 trials. No third-party import.
"""

from __future__ import annotations

import math
from typing import Sequence

__all__ = ["LEVEL", "METHOD", "successes_of", "clopper_pearson", "step_interval",
           "robustness_interval"]

LEVEL = 0.95
#: what the intervals are, in words (stated in the plan's JSON and the README)
METHOD = "Clopper-Pearson per step; R: Bonferroni product of per-step Clopper-Pearson bounds"

_HALVINGS = 60


def successes_of(score: float, trials: int) -> int:
    """The success count behind ``score = successes / trials``. Raises ``ValueError`` when
    ``trials < 1`` or the score is outside [0, 1]."""
    if trials < 1:
        raise ValueError(f"trials must be at least 1, not {trials}")
    if not 0.0 <= score <= 1.0:
        raise ValueError(f"a score is a success rate in [0, 1], not {score}")
    return int(round(score * trials))


def _tail_at_least(k: int, n: int):
    """p -> P(X >= k) for X ~ Binomial(n, p) (log binomial coefficients computed once)."""
    log_c = [math.lgamma(n + 1) - math.lgamma(i + 1) - math.lgamma(n - i + 1)
             for i in range(k, n + 1)]

    def tail(p: float) -> float:
        if p <= 0.0:
            return 1.0 if k == 0 else 0.0
        if p >= 1.0:
            return 1.0
        lp, lq = math.log(p), math.log1p(-p)
        logs = [c + i * lp + (n - i) * lq for c, i in zip(log_c, range(k, n + 1))]
        top = max(logs)
        return min(1.0, math.exp(top) * sum(math.exp(v - top) for v in logs))

    return tail


def _bisect(f, target: float) -> float:
    """The p in [0, 1] where the increasing function ``f`` crosses ``target``."""
    lo, hi = 0.0, 1.0
    for _ in range(_HALVINGS):
        mid = (lo + hi) / 2
        if f(mid) < target:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def clopper_pearson(successes: int, trials: int, level: float = LEVEL) -> tuple[float, float]:
    """The two-sided Clopper-Pearson interval ``(lo, hi)`` of a binomial rate at ``level``.
    Raises ``ValueError`` for counts out of range or a level outside (0, 1)."""
    k, n = int(successes), int(trials)
    if n < 1 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= successes <= trials and trials >= 1, got {k}/{n}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), not {level}")
    half = (1.0 - level) / 2
    # P(X >= k | p) increases with p: lo is where it reaches alpha/2
    lo = 0.0 if k == 0 else _bisect(_tail_at_least(k, n), half)
    # P(X <= k | p) = 1 - P(X >= k+1 | p) decreases with p: hi is where it falls to alpha/2
    hi = 1.0 if k == n else _bisect(_tail_at_least(k + 1, n), 1.0 - half)
    return lo, hi


def step_interval(score: float | None, trials: int | None,
                  level: float = LEVEL) -> tuple[float, float] | None:
    """A step's Clopper-Pearson interval from its score and trials (None when either is
    unknown)."""
    if score is None or trials is None:
        return None
    return clopper_pearson(successes_of(score, trials), trials, level)


def robustness_interval(scores: Sequence[float | None], trials: int | None,
                        level: float = LEVEL) -> tuple[float, float] | None:
    """R's interval at ``level``: the Bonferroni product of the steps' Clopper-Pearson bounds,
    each at ``1 - (1 - level) / m`` (module doc). None when a score or the trials are unknown;
    ``(1.0, 1.0)`` for a plan of no steps (R = 1 exactly)."""
    if trials is None or any(s is None for s in scores):
        return None
    m = len(scores)
    if m == 0:
        return 1.0, 1.0
    each = 1.0 - (1.0 - level) / m
    lo = hi = 1.0
    for s in scores:
        a, b = clopper_pearson(successes_of(s, trials), trials, each)  # type: ignore[arg-type]
        lo, hi = lo * a, hi * b
    return lo, hi
