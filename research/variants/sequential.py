"""Sequential tests of a success rate: stop an operation's trials once a comparison is decided.

A verification simulation often only has to say whether an operation's success rate ``p`` is at
least a threshold ``tau`` (whether it can still beat an incumbent). ``SequentialTest`` runs its
trials in *chunks* (``chunks``, e.g. 20, 20, 20: separate simulator runs with their own seeds,
``rap.seeds.chunk_seed``; the simulator's trials of one run are not a prefix of a longer run's)
and looks after each chunk, at the cumulative trial counts ``looks`` (20, 40, 60):

* ``below`` when the Clopper-Pearson upper bound of ``p`` at level ``alpha`` is under ``tau``;
* ``above`` when the Clopper-Pearson lower bound is over ``tau``;
* else ``undecided`` (after the last chunk the caller runs the fixed 100-trial simulation).

Error rate: ``alpha = delta / (2 K)`` with ``K = len(chunks)`` looks. Clopper-Pearson's bounds are
exact (conservative) for a binomial count at a fixed ``n``: ``P(upper(X, n) < p) <= alpha`` and
``P(lower(X, n) > p) <= alpha`` for every ``p``. A wrong ``below`` (``p >= tau``) needs the upper
bound under ``p`` at one of the ``K`` looks, a wrong ``above`` (``p <= tau``) the lower bound over
``p`` at one of them: by the union bound over the ``2 K`` events, whatever the stopping rule and
whatever thresholds are compared at each look (even thresholds that change between looks, or
depend on the data: the events do not involve ``tau``), a test errs with probability at most
``delta`` (for ``p = tau`` both decisions count as errors and together stay within ``delta``).
The looks must be at the schedule's counts (``decide`` refuses others): the union runs over them.
Precondition: the chunks' outcomes are independent Bernoulli(``p``) trials (each chunk is its own
simulation from its own seed; within one run the simulator's trials share a space but never touch).

Clopper-Pearson rather than a Hoeffding or Bernstein bound: at 10 to 60 trials and rates near 0
or 1 (most operations) it is several times tighter, and it needs no variance estimate. Computed
by bisection on the exact binomial tail (no scipy). Pure; cost: O(n) per tail evaluation, 60
bisection steps, memoised per (successes, trials, level).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from rap.stats import clopper_pearson

__all__ = ["SequentialTest", "DEFAULT_CHUNKS", "BELOW", "ABOVE", "UNDECIDED", "upper_bound",
           "lower_bound"]

#: trials per chunk: one look, at 10 trials; an operation not shown below then gets its fixed
#: 100-trial simulation (110 trials in all). Chosen on the fresh validation tables (replayed,
#: research/sequential_replay.py) as the least costly of 10; 20; 10, 20, 30; 20, 20, 20: every
#: one of them cost the default search more trials than it saved (docs/RESULTS.md)
DEFAULT_CHUNKS = (10,)
BELOW, ABOVE, UNDECIDED = "below", "above", "undecided"


@lru_cache(maxsize=4096)
def upper_bound(successes: int, trials: int, alpha: float) -> float:
    """Clopper-Pearson upper bound: the largest ``p`` with ``P(X <= successes) >= alpha``
    (``P(upper_bound(X) < p) <= alpha`` for every ``p``); 1 when every trial succeeded. The
    one-sided bound at ``alpha`` is the two-sided interval's end at level ``1 - 2 alpha``
    (``rap.stats.clopper_pearson``)."""
    if not 0 <= successes <= trials or trials < 1:
        raise ValueError(f"{successes} successes of {trials} trials")
    if successes == trials:
        return 1.0
    return clopper_pearson(successes, trials, 1.0 - 2.0 * alpha)[1]


def lower_bound(successes: int, trials: int, alpha: float) -> float:
    """Clopper-Pearson lower bound (``P(lower_bound(X) > p) <= alpha``); 0 with no success."""
    return 1.0 - upper_bound(trials - successes, trials, alpha)


@dataclass(frozen=True)
class SequentialTest:
    """Whether a success rate is below or above a threshold, at error rate ``delta`` over the
    looks after each of ``chunks`` (module doc)."""

    delta: float = 0.05
    chunks: tuple[int, ...] = DEFAULT_CHUNKS

    def __post_init__(self):
        if not 0.0 < self.delta < 1.0:
            raise ValueError(f"delta {self.delta}: choose an error rate in (0, 1)")
        if not self.chunks or any(int(c) < 1 for c in self.chunks):
            raise ValueError(f"chunks {self.chunks}: at least one, each of at least one trial")

    @property
    def alpha(self) -> float:
        """The level of each bound at each look: ``delta / (2 len(chunks))``."""
        return self.delta / (2 * len(self.chunks))

    @property
    def looks(self) -> tuple[int, ...]:
        """The cumulative trial counts after each chunk."""
        return tuple(sum(self.chunks[:i + 1]) for i in range(len(self.chunks)))

    def upper(self, successes: int, trials: int) -> float:
        """The upper bound at a look (what an operation stopped ``below`` counts as, at most)."""
        return upper_bound(successes, self._at_look(trials), self.alpha)

    def lower(self, successes: int, trials: int) -> float:
        return lower_bound(successes, self._at_look(trials), self.alpha)

    def decide(self, successes: int, trials: int, tau: float) -> str:
        """``BELOW``, ``ABOVE`` or ``UNDECIDED`` for ``p`` against ``tau`` after ``trials``
        (one of ``looks``) with ``successes``."""
        if self.upper(successes, trials) < tau:
            return BELOW
        if self.lower(successes, trials) > tau:
            return ABOVE
        return UNDECIDED

    def _at_look(self, trials: int) -> int:
        if trials not in self.looks:
            raise ValueError(f"{trials} trials: the test looks only at {self.looks}")
        return trials
