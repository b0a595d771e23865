"""The binomial statistics of simulator scores, in one place: tails, exact intervals, union bounds.

A score is ``successes / trials`` of the simulator's noisy trials (``rap.sim.params.SimParams``),
so every confidence statement about scores is about a binomial rate:

* ``log_comb(n, j)``, ``binomial_tail(p, n, k)``: ``P(Bin(n, p) >= k)`` for an array of rates,
  summed in log space (the numpy engine's P(high); ``rap.model.network.heads`` has the torch twin
  that training differentiates, on the same ``log_comb``); ``high_count(threshold, trials)``: the
  least success count whose score reaches a threshold.
* ``successes_of(score, trials)``, ``clopper_pearson(successes, trials, level)``: the exact
  two-sided interval of one rate (coverage at least the level for every true rate).
* ``bonferroni(confidence, steps)``: the per-item level at which ``steps`` statements hold together
  with probability at least ``confidence`` (the union bound; no independence needed).
* ``Rate``, ``rate(successes, trials)``: a measured success count (executed plans, rollouts) with
  its 95% Clopper-Pearson interval, the same construction as a step's score interval.
* ``expected_attempts(score)``: the mean number of attempts of a step retried until it succeeds,
  ``1/r`` (geometric; infinite for a score of 0): a plan's sum and the optimum's other objective.

Floats only (statistics, not geometry); numpy and the standard library. A Clopper-Pearson bound
is found by bisection on the tail (60 halvings: below 1e-15), each tail ``trials + 1`` terms:
about 0.1 ms for 100 trials.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["log_comb", "high_count", "binomial_tail", "tail_at_least", "successes_of",
           "clopper_pearson", "bonferroni", "check_level", "expected_attempts", "Rate", "rate",
           "RATE_LEVEL"]

RATE_LEVEL = 0.95  # the level of a measured rate's interval (``rate``)

_HALVINGS = 60


def check_level(level: float) -> float:
    """``level`` as a float in (0, 1]; ``ValueError`` otherwise."""
    level = float(level)
    if not 0.0 < level <= 1.0:
        raise ValueError(f"level {level!r}: choose a number in (0, 1]")
    return level


def log_comb(n: int, j: int) -> float:
    """``log(n choose j)``."""
    return math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1)


def high_count(threshold: float, trials: int) -> int:
    """The least number of successes out of ``trials`` whose score is >= ``threshold``."""
    return max(0, math.ceil(threshold * trials - 1e-9))


def binomial_tail(p: np.ndarray, n: int, k: int) -> np.ndarray:
    """``P(Bin(n, p) >= k)`` elementwise over an array of rates, in float64, summed in log space.
    O(len(p) (n - k + 1))."""
    p = np.asarray(p, dtype=np.float64)
    if k <= 0:
        return np.ones_like(p)
    if k > n:
        return np.zeros_like(p)
    p = np.clip(p, 1e-12, 1 - 1e-12)
    lp, lq = np.log(p), np.log1p(-p)
    terms = np.stack([log_comb(n, j) + j * lp + (n - j) * lq for j in range(k, n + 1)])
    m = terms.max(axis=0)
    return np.clip(np.exp(m + np.log(np.exp(terms - m).sum(axis=0))), 0.0, 1.0)


def tail_at_least(k: int, n: int):
    """``p -> P(X >= k)`` for ``X ~ Binomial(n, p)``, a scalar function (log binomial coefficients
    computed once)."""
    log_c = [log_comb(n, i) for i in range(k, n + 1)]

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


def successes_of(score: float, trials: int) -> int:
    """The success count behind ``score = successes / trials``. Raises ``ValueError`` when
    ``trials < 1`` or the score is outside [0, 1]."""
    if trials < 1:
        raise ValueError(f"trials must be at least 1, not {trials}")
    if not 0.0 <= score <= 1.0:
        raise ValueError(f"a score is a success rate in [0, 1], not {score}")
    return int(round(score * trials))


def clopper_pearson(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """The two-sided Clopper-Pearson interval ``(lo, hi)`` of a binomial rate at ``level``:
    ``P(X >= k | lo) = alpha / 2`` and ``P(X <= k | hi) = alpha / 2`` (``lo = 0`` when ``k = 0``,
    ``hi = 1`` when ``k = n``). Raises ``ValueError`` for counts out of range or a level outside
    (0, 1)."""
    k, n = int(successes), int(trials)
    if n < 1 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= successes <= trials and trials >= 1, got {k}/{n}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), not {level}")
    half = (1.0 - level) / 2
    # P(X >= k | p) increases with p: lo is where it reaches alpha/2
    lo = 0.0 if k == 0 else _bisect(tail_at_least(k, n), half)
    # P(X <= k | p) = 1 - P(X >= k+1 | p) decreases with p: hi is where it falls to alpha/2
    hi = 1.0 if k == n else _bisect(tail_at_least(k + 1, n), 1.0 - half)
    return lo, hi


def bonferroni(confidence: float, steps: int) -> float:
    """The per-item level at which ``steps`` statements hold together with probability at least
    ``confidence`` (the union bound): ``1 - (1 - confidence) / steps`` (``steps`` < 1 counts 1)."""
    return 1.0 - (1.0 - check_level(confidence)) / max(1, int(steps))


def expected_attempts(score: float) -> float:
    """The expected attempts of a step of score ``r`` retried until it succeeds, ``1/r`` (the
    mean of a geometric distribution); infinite for a score of 0 (it never succeeds)."""
    return 1.0 / score if score > 0.0 else math.inf


@dataclass(frozen=True)
class Rate:
    """``successes`` of ``trials`` with the Clopper-Pearson interval ``[low, high]`` at
    ``RATE_LEVEL``."""

    successes: int
    trials: int
    low: float
    high: float

    @property
    def value(self) -> float:
        return self.successes / self.trials if self.trials else float("nan")

    @property
    def half_width(self) -> float:
        return (self.high - self.low) / 2

    def text(self) -> str:
        return f"{self.value:.3f} [{self.low:.3f}, {self.high:.3f}] ({self.successes}/{self.trials})"

    def to_dict(self) -> dict:
        return {"successes": self.successes, "trials": self.trials, "rate": self.value,
                "interval": [self.low, self.high], "level": RATE_LEVEL}


def rate(successes: int, trials: int) -> Rate:
    """The rate ``successes / trials`` with its Clopper-Pearson interval at ``RATE_LEVEL``."""
    lo, hi = clopper_pearson(successes, trials, RATE_LEVEL)
    return Rate(int(successes), int(trials), float(lo), float(hi))
