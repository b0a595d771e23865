"""A per-assembly correction of the model's scores, fitted on the operations one search simulated.

The shipped model's expected score ``p`` is biased per assembly, and differently at different
``p``: on one held-out assembly its operations predicted near 0.85 succeed less often than
predicted while those near 0.97 do not, on another the other way round (docs/RESULTS.md). A search
that has simulated ``n`` operations of an assembly knows ``n`` pairs ``(p, s)`` of that assembly
and can correct the ``p`` of every operation it has not simulated. ``ScoreCorrection(prior,
edges)`` is a shrunk residual in logit space, per bin of ``p``:

    r       = logit s~ - logit p~                 (one simulated operation's residual)
    pooled  = sum of all r / (n + prior)           (shrunk towards no correction)
    shift_b = (sum of bin b's r + prior pooled) / (n_b + prior)   (shrunk towards pooled)
    corrected(p) = the q with q~ = sigmoid(logit p~ + shift_b), b the bin of p,

where ``x~ = (trials x + 1/2) / (trials + 1)`` keeps a score off 0 and 1 (Laplace's rule on a
score of ``trials`` trials; applied to ``p`` too, so a pair with ``s = p`` adds nothing). The bins
are ``p < edges[0]``, ``edges[0] <= p < edges[1]``, ...; ``edges = ()`` is one bin: one shift,
``pooled`` shrunk twice. ``prior`` is the strength, in pseudo-operations, of the prior "the model
is unbiased here" (and, per bin, "this bin is as the others"): with ``prior = 5`` five simulations
move a shift half way to their mean residual. Before the first pair the correction is the
identity. Within a bin it is monotone in ``p``; across an edge two operations can swap (their
bins' shifts differ).

Selection: a search simulates the operations it is most unsure of (mostly mid-range ``p``, where
the bounds are wide), not a random sample. The choice depends on the model's outputs and the
simulated scores of *other* operations, never on the operation's own simulated score, so given
``p`` the simulated residuals are unbiased for the unsimulated ones (missing at random given
``p``); a bias that differs with ``p`` is what the bins are for (one shift fitted on mid-range
operations lowers the high ones the plan is made of). The search's stopping does depend on the
residuals seen (a run of low scores makes it go on simulating), which a long search's residuals
lean towards.

Measured (``research/bound_coverage.py``, settings ``-aK``; ``SearchPlanner(adapt=K)``, off by
default): with ``prior`` 2 at ``plan``'s defaults (200 simulations, upper 0.35, gap 0.05) the search
stops sooner (fresh validation: 24 simulations a plan instead of 40, unseen: 38 instead of 57) for
a little less robustness (R / R opt 0.987 instead of 0.994, 0.993 instead of 0.997); at budgets of
40 and 80 simulations it is more robust than without (fresh: 0.987 against 0.983 at both;
unseen: 0.983 against 0.972, 0.993 against 0.987). About what a smaller ``upper`` gives without
it, and a fixed shift of -0.1 in logit (learnt from nothing) did as well.

Cost: ``add`` and ``__call__`` O(log bins); a search with a correction redoes its dynamic
programme over the whole graph after each round (replays 1.5 to 2 times as long). No numpy.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

__all__ = ["ScoreCorrection", "TRIALS", "EDGES"]

TRIALS = 100  # trials behind a simulated score (rap.plan.scoring.scorer' default)
#: the bins of ``p``: where held-out operations' residuals differ (research/bound_coverage.py)
EDGES = (0.8, 0.9, 0.95, 0.98)


def _logit(x: float, trials: int) -> float:
    x = (trials * min(max(x, 0.0), 1.0) + 0.5) / (trials + 1)
    return math.log(x / (1.0 - x))


@dataclass
class ScoreCorrection:
    """One search's shrunk logit residuals per bin of ``p`` (module doc). ``prior`` >= 0 (0: the
    plain mean residuals, no shrinkage); ``edges``: increasing, in (0, 1)."""

    prior: float = 5.0
    edges: tuple = EDGES
    trials: int = TRIALS
    total: float = 0.0  # sum of all residuals
    count: int = 0
    bins: dict = field(default_factory=dict)  # bin index -> [sum of its residuals, count]

    def __post_init__(self):
        if not self.prior >= 0.0:
            raise ValueError(f"prior {self.prior!r}: choose a number >= 0")
        self.edges = tuple(float(e) for e in self.edges)
        e = (0.0,) + self.edges + (1.0,)
        if any(not a < b for a, b in zip(e, e[1:])):
            raise ValueError(f"edges {self.edges!r}: increasing numbers in (0, 1)")

    def _bin(self, p: float) -> int:
        return bisect.bisect_right(self.edges, p)

    def add(self, predicted: float, simulated: float) -> None:
        """One simulated operation: its model score ``predicted`` and simulated score."""
        r = _logit(simulated, self.trials) - _logit(predicted, self.trials)
        self.total += r
        self.count += 1
        b = self.bins.setdefault(self._bin(predicted), [0.0, 0])
        b[0] += r
        b[1] += 1

    @property
    def pooled(self) -> float:
        """The shift of all bins together, shrunk towards 0 (0 before the first pair)."""
        return self.total / (self.count + self.prior) if self.count else 0.0

    def shift(self, p: float) -> float:
        """The logit shift of a score ``p``: its bin's, shrunk towards ``pooled``."""
        if not self.count:
            return 0.0
        total, n = self.bins.get(self._bin(p), (0.0, 0))
        if n + self.prior == 0.0:
            return self.pooled
        return (total + self.prior * self.pooled) / (n + self.prior)

    def __call__(self, p: float) -> float:
        """The corrected expected score of an operation the model scores ``p`` (in [0, 1])."""
        shift = self.shift(p)
        if shift == 0.0:
            return p
        z = _logit(p, self.trials) + shift
        q = 1.0 / (1.0 + math.exp(-z)) if z >= 0 else math.exp(z) / (1.0 + math.exp(z))
        return min(max(((self.trials + 1) * q - 0.5) / self.trials, 0.0), 1.0)
