"""Test-only stand-ins for the planners' backends (never imported by shipped code).

* ``HashSim``: a fast deterministic fake simulator: the score of an operation is a function of its
  content key (so equal operations score equally in every process), in steps of 1/``trials``.
* ``TableCnn``: a fake CNN returning P(high) from a function of the operation, and an expected
  score from another (the same one by default).
"""

from __future__ import annotations

import hashlib

import numpy as np

from rap.plan.cache import CachedScore


def hash_score(op, trials: int = 20) -> float:
    h = int(hashlib.sha256(op.key("standin").encode()).hexdigest()[:8], 16)
    # most operations robust-ish, some not: successes in [trials/2, trials]
    s = trials // 2 + h % (trials - trials // 2 + 1)
    return s / trials


class HashSim:
    def __init__(self, trials: int = 20):
        self.trials = trials
        self.calls = 0
        self.ops = 0

    def simulate_many(self, problem, ops):
        self.calls += 1
        self.ops += len(ops)
        out = []
        for op in ops:
            sc = hash_score(op, self.trials)
            out.append(CachedScore(sc, int(round(sc * self.trials)), self.trials))
        return out


class TableCnn:
    def __init__(self, fn, score_fn=None):
        self.fn = fn
        self.score_fn = score_fn or fn
        self.batches = []
        self.scored = 0

    def prob_high(self, problem, ops):
        self.batches.append(len(ops))
        return np.array([self.fn(op) for op in ops], dtype=np.float64)

    def expected_score(self, problem, ops):
        self.scored += len(ops)
        return np.array([self.score_fn(op) for op in ops], dtype=np.float64)
