"""research.variants.chunks: the chunks of sequential tests are their own seeded simulator runs."""

from __future__ import annotations
import os
import signal
import sys
from types import SimpleNamespace
import pytest
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.sim.params import SimParams
from tests.plan.cases import ROW3, memory
from research.variants.chunks import ChunkedLocalSimulator


def _problem():
    problem = PlanningProblem(memory(ROW3), SimParams(trials=6), root_seed=11)
    return problem, list(problem.candidates(problem.whole))


def test_chunks_are_their_own_seeded_runs_in_every_configuration():
    import numpy as np

    from research.variants.chunks import chunk_seed
    from rap.sim.simulator import simulate

    problem, ops = _problem()
    chunks = [(op, i, n) for op in ops[:2] for i, n in enumerate((4, 8))]
    here = ChunkedLocalSimulator().simulate_chunks(problem, chunks)
    sim = ChunkedLocalSimulator(processes=2, min_batch=2)
    try:
        pooled = sim.simulate_chunks(problem, chunks)
    finally:
        sim.close()
    assert pooled == here and [c.trials for c in here] == [4, 8, 4, 8]
    op, i, n = chunks[1]  # the simulator itself, from the chunk's seed and trials
    direct = simulate(problem.assembly, op, problem.params.with_(trials=n),
                      np.random.default_rng(chunk_seed(problem.seed(op), i)))
    assert (here[1].successes, here[1].trials) == (direct.successes, direct.trials)
