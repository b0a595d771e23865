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

The statistics themselves (Clopper-Pearson, the union bound) are ``rap.stats``'s; about 0.1 ms a
step for 100 trials.
"""

from __future__ import annotations

from typing import Sequence

from rap.stats import clopper_pearson, successes_of

__all__ = ["LEVEL", "METHOD", "step_interval", "robustness_interval"]

LEVEL = 0.95
#: what the intervals are, in words (stated in the plan's JSON and the README)
METHOD = "Clopper-Pearson per step; R: Bonferroni product of per-step Clopper-Pearson bounds"

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
