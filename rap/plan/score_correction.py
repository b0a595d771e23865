"""A per-assembly correction of the model's scores, fitted on the operations one search simulated.

The shipped model's expected score ``p`` is biased per assembly: on some assemblies its operations
succeed less often than predicted, on others more (docs/RESULTS.md). A search that has simulated
``n`` operations of an assembly knows ``n`` pairs ``(p, s)`` of that assembly and can correct the
``p`` of every operation it has not simulated. ``ScoreCorrection(prior)`` is the simplest such
correction: one shift in logit space, shrunk towards none,

    shift = sum over the pairs of (logit s~ - logit p~) / (n + prior),
    corrected(p) = the p whose p~ is sigmoid(logit p~ + shift),

where ``x~ = (trials x + 1/2) / (trials + 1)`` keeps a score off 0 and 1 (Laplace's rule on a
score of ``trials`` trials: 0 and 1 stay finite; applied to ``p`` too, so a pair with ``s = p``
adds nothing). ``prior`` is the strength of the prior "the model is unbiased here", in
pseudo-operations: with ``prior = 5`` five simulations move the shift half way to their mean
residual. The correction is monotone in ``p`` (it never reorders two unsimulated operations) and
the identity before the first pair (``shift = 0``).

Selection: a search simulates the operations it is most unsure of, not a random sample. The choice
depends only on the model's outputs and the simulated scores of *other* operations, never on the
operation's own simulated score, so given ``p`` the simulated residuals are unbiased for the
unsimulated ones (missing at random given ``p``); what the one-parameter shift does not model is a
bias that differs with ``p`` (the shift is one number for all ``p``).

Cost: ``add`` O(1); ``__call__`` O(1). No numpy, no torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ScoreCorrection", "TRIALS"]

TRIALS = 100  # trials behind a simulated score (rap.plan.scorers' default)


def _logit(x: float, trials: int) -> float:
    x = (trials * min(max(x, 0.0), 1.0) + 0.5) / (trials + 1)
    return math.log(x / (1.0 - x))


@dataclass
class ScoreCorrection:
    """One search's shrunk logit shift of the model's scores (module doc). ``prior`` >= 0 (0: the
    plain mean residual, no shrinkage)."""

    prior: float = 5.0
    trials: int = TRIALS
    total: float = 0.0  # sum of the residuals logit s~ - logit p~
    count: int = 0

    def __post_init__(self):
        if not self.prior >= 0.0:
            raise ValueError(f"prior {self.prior!r}: choose a number >= 0")

    def add(self, predicted: float, simulated: float) -> None:
        """One simulated operation: its model score ``predicted`` and simulated score."""
        self.total += _logit(simulated, self.trials) - _logit(predicted, self.trials)
        self.count += 1

    @property
    def shift(self) -> float:
        """The logit shift (0 before the first pair)."""
        if not self.count:
            return 0.0
        return self.total / (self.count + self.prior)

    def __call__(self, p: float) -> float:
        """The corrected expected score of an operation the model scores ``p`` (in [0, 1])."""
        shift = self.shift
        if shift == 0.0:
            return p
        z = _logit(p, self.trials) + shift
        q = 1.0 / (1.0 + math.exp(-z)) if z >= 0 else math.exp(z) / (1.0 + math.exp(z))
        return min(max(((self.trials + 1) * q - 0.5) / self.trials, 0.0), 1.0)
