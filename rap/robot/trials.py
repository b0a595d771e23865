"""Success counts of executed plans and their 95% Clopper-Pearson intervals.

``rate(successes, trials)`` is a ``Rate``: the count, the trials, the fraction and its exact
(Clopper-Pearson) interval at ``rap.plan.report.intervals.LEVEL`` (95%), the same construction as
a step's score interval, so the measured success of a plan and its R are compared on one footing.
Pure; O(trials) bisection steps per bound.
"""

from __future__ import annotations

from dataclasses import dataclass

from rap.plan.report.intervals import LEVEL, clopper_pearson

__all__ = ["Rate", "rate"]


@dataclass(frozen=True)
class Rate:
    successes: int
    trials: int
    low: float
    high: float

    @property
    def value(self) -> float:
        return self.successes / self.trials if self.trials else float("nan")

    def text(self) -> str:
        return f"{self.value:.3f} [{self.low:.3f}, {self.high:.3f}] ({self.successes}/{self.trials})"

    def to_dict(self) -> dict:
        return {"successes": self.successes, "trials": self.trials, "rate": self.value,
                "interval": [self.low, self.high], "level": LEVEL}


def rate(successes: int, trials: int) -> Rate:
    """The rate ``successes / trials`` with its Clopper-Pearson interval (module doc)."""
    lo, hi = clopper_pearson(successes, trials, LEVEL)
    return Rate(int(successes), int(trials), float(lo), float(hi))
