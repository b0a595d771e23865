"""Test-only stand-ins for the planners' backends (never imported by shipped code).

* ``HashSim``: a fast deterministic fake simulator: the score of an operation is a function of its
  content key (so equal operations score equally in every process), in steps of 1/``trials``.
* ``BinomialSim``: a fake simulator with the chunks of sequential tests: an operation's label is
  ``score_fn(op)`` in steps of 1/``trials``; chunk ``index`` of ``n`` trials is ``Binomial(n,
  score)`` drawn from the chunk's seed (``rap.seeds.chunk_seed``), so chunks are deterministic.
* ``TableCnn``: a fake CNN returning P(high) from a function of the operation, and an expected
  score from another (the same one by default).
"""

from __future__ import annotations

import hashlib

import numpy as np

from rap.plan.scoring.cache import CachedScore


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


class BinomialSim:
    def __init__(self, score_fn, trials: int = 100):
        self.score_fn = score_fn
        self.trials = trials
        self.labels = 0  # full simulations run
        self.chunks = []  # (op key, index, trials) of every chunk run

    def simulate_many(self, problem, ops):
        self.labels += len(ops)
        out = []
        for op in ops:
            s = int(round(self.score_fn(op) * self.trials))
            out.append(CachedScore(s / self.trials, s, self.trials))
        return out

    def simulate_chunks(self, problem, chunks):
        from rap.seeds import chunk_seed

        out = []
        for op, index, n in chunks:
            self.chunks.append((problem.key(op), index, n))
            rng = np.random.default_rng(chunk_seed(problem.seed(op), index))
            s = int(rng.binomial(n, self.score_fn(op)))
            out.append(CachedScore(s / n, s, n))
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
