"""The hooks of sequential tests, kept beside them (``research.variants.sequential``): measured to
save nothing (docs/RESULTS.md, research/README.md), so the shipped scorer and simulator no longer
carry them.

* ``chunk_seed(seed, index)``: the seed of chunk ``index`` of an operation's sequential test from
  the operation's own seed (``rap.seeds.derive_seed``): a separate simulator run, never the
  label's.
* ``ChunkedLocalSimulator``: ``rap.plan.scoring.local_simulator.LocalSimulator`` that also runs
  chunks (``simulate_chunks(problem, [(op, index, trials), ...])``).
* ``ChunkScorer``: ``rap.plan.scoring.scorer.Scorer`` with ``chunks(problem, chunks)`` (one
  backend call, never cached: a chunk is not a label) and a budget that counts a chunk as its
  share of a simulation.

Research only. The search's own hooks for them (``SearchPlanner(sequential=...)``,
``SearchScores.partial``) were removed in 0.3.0; ``research/sequential_replay.py``'s figures were
measured at commit 48873fe (``git worktree add /tmp/v020 48873fe`` to replay them).
"""

from __future__ import annotations

import time
from typing import Sequence

import numpy as np

from rap.operation import Operation
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.cache import CachedScore
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.scoring.scorer import BudgetSpent, Scorer

__all__ = ["chunk_seed", "ChunkedLocalSimulator", "ChunkScorer"]

_CHUNK_TAG = 0x5E9C  # keeps chunk seeds apart from any seed spawned from the same words elsewhere


def chunk_seed(seed: int, index: int) -> int:
    """A 63-bit seed for chunk ``index`` (0, 1, ...) of the operation whose simulator seed is
    ``seed``: deterministic, distinct per (seed, index), and never ``seed`` itself. O(1)."""
    if index < 0:
        raise ValueError(f"chunk index {index}: must be non-negative")
    seed = int(seed)
    ss = np.random.SeedSequence([seed & 0xFFFFFFFF, (seed >> 32) & 0xFFFFFFFF, _CHUNK_TAG,
                                 int(index)])
    return int(ss.generate_state(2, dtype=np.uint64)[0]) & ((1 << 63) - 1)


class ChunkedLocalSimulator(LocalSimulator):
    """A local simulator that also runs the chunks of sequential tests."""

    def simulate_chunks(self, problem: PlanningProblem,
                        chunks: Sequence[tuple[Operation, int, int]]) -> list[CachedScore]:
        """Each ``(op, index, trials)``: ``trials`` trials from ``chunk_seed(problem.seed(op),
        index)``, in input order."""
        return self._run([(problem.assembly, op, problem.params.with_(trials=int(n)),
                           chunk_seed(problem.seed(op), int(i))) for op, i, n in chunks])


class ChunkScorer(Scorer):
    """A scorer whose simulator backend runs chunks (``simulate_chunks``)."""

    chunk_trials: int = 0
    chunk_runs: int = 0

    def _spent(self, problem: PlanningProblem) -> float:
        """Fresh simulations so far, a chunk counting its share of a full one."""
        return self.stats.sim_run + self.chunk_trials / problem.params.trials

    @property
    def chunked(self) -> bool:
        """Whether the simulator backend runs the chunks of sequential tests."""
        return hasattr(self.simulator, "simulate_chunks")

    def chunks(self, problem: PlanningProblem,
               chunks: Sequence[tuple[Operation, int, int]]) -> list[CachedScore]:
        """Each ``(op, index, trials)`` simulated as chunk ``index`` of ``op``'s sequential test
        (``trials`` trials, its own seed), in input order; one backend call, not cached. A budget
        of simulations counts ``trials / problem.params.trials`` of one per chunk."""
        self._check_time()
        chunks = list(chunks)
        if not chunks:
            return []
        st, b = self.stats, self.budget
        if b.max_simulations is not None and (self._spent(problem) + sum(n for _, _, n in chunks)
                                              / problem.params.trials > b.max_simulations):
            raise BudgetSpent(f"simulation budget of {b.max_simulations} spent")
        self._progress(len(chunks))
        t = time.perf_counter()
        got = self.simulator.simulate_chunks(problem, chunks)
        st.sim_seconds += time.perf_counter() - t
        st.sim_calls += 1
        if len(got) != len(chunks):
            raise RuntimeError("simulator backend returned a wrong number of results")
        self.chunk_runs += len(chunks)
        self.chunk_trials += sum(c.trials for c in got)
        st.sim_trials += sum(c.trials for c in got)
        self._progress(0)
        return list(got)
