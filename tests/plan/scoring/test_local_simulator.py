"""LocalSimulator's worker processes: prestarted (a one-off `rap-farm plan`), broken, closed."""

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

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="worker processes are forked on Linux only")


def _problem():
    problem = PlanningProblem(memory(ROW3), SimParams(trials=6), root_seed=11)
    return problem, list(problem.candidates(problem.whole))


def test_prestarted_workers_take_every_batch_and_give_the_in_process_scores():
    problem, ops = _problem()
    sim = LocalSimulator(processes=2, prestart=True)
    try:
        assert sim.prestarted and len(sim.workers) == 2  # forked at construction
        one = sim.simulate_many(problem, ops[:1])  # a batch of one goes to the workers too
        pooled = sim.simulate_many(problem, ops)
    finally:
        sim.close()
    here = LocalSimulator().simulate_many(problem, ops)
    assert pooled == here and one == here[:1]


def test_worker_processes_give_the_in_process_scores():
    problem, ops = _problem()
    assert len(ops) >= 2
    sim = LocalSimulator(processes=2, min_batch=2)
    try:
        pooled = sim.simulate_many(problem, ops)
        assert len(sim.workers) == 2  # a batch of min_batch operations went to the workers
    finally:
        sim.close()
    assert pooled == LocalSimulator().simulate_many(problem, ops)


def test_close_stops_workers_that_are_still_loading():
    sim = LocalSimulator(processes=2, prestart=True)
    workers = list(sim.workers)
    assert len(workers) == 2
    sim.close()
    assert sim.workers == []
    assert all(not w.is_alive() for w in workers)


def test_a_killed_worker_falls_back_to_this_process():
    problem, ops = _problem()
    sim = LocalSimulator(processes=2, prestart=True)
    try:
        sim.simulate_many(problem, ops[:1])
        for w in list(sim.workers):
            os.kill(w.pid, signal.SIGKILL)
            w.join()
        scores = sim.simulate_many(problem, ops)
        assert not sim.prestarted and sim.workers == []
    finally:
        sim.close()
    assert scores == LocalSimulator().simulate_many(problem, ops)


def test_an_injected_simulator_is_never_forked():
    calls = []

    def fake(assembly, op, params, rng):
        calls.append(op)
        return SimpleNamespace(score=1.0, successes=params.trials, trials=params.trials)

    problem, ops = _problem()
    sim = LocalSimulator(fake, processes=2, prestart=True)
    assert not sim.prestarted and sim.workers == []
    assert [s.score for s in sim.simulate_many(problem, ops)] == [1.0] * len(ops)
    assert calls == ops


_SIGTERM_AT_FORK: list[int] = []  # while not empty, each fork in this process sends it SIGTERM


def _sigterm_if_armed() -> None:
    if _SIGTERM_AT_FORK:
        os.kill(os.getpid(), signal.SIGTERM)


os.register_at_fork(after_in_parent=_sigterm_if_armed)


def test_sigterm_while_the_workers_are_forked_stops_them_and_is_raised(monkeypatch):
    """SIGTERM as the CLI makes it (a handler that raises KeyboardInterrupt) arriving while the
    pool forks: inside an at-fork hook (logging's; here the one that sends it) the exception
    would be printed and dropped, and the command would go on. It is raised once the forks are
    done, and no worker is left."""
    import rap.plan.scoring.local_simulator as local

    made = []
    real = local._fork_context
    monkeypatch.setattr(local, "_fork_context", lambda started: made.append(started)
                        or real(started))

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGTERM, interrupt)
    _SIGTERM_AT_FORK.append(1)
    try:
        with pytest.raises(KeyboardInterrupt):
            LocalSimulator(processes=2, prestart=True)
    finally:
        _SIGTERM_AT_FORK.clear()
        signal.signal(signal.SIGTERM, before)
    (workers,) = made
    assert len(workers) == 2 and all(not w.is_alive() for w in workers)
