"""SimPool: input order, determinism across worker counts, bounded in-flight, retries."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from rap.io import load_assembly
from rap.enumerate import label_key, label_seed
from rap.sim.params import SimParams

from tests.farm import standin
from tests.farm.conftest import ASSEMBLIES, FAKE, REAL

pytestmark = pytest.mark.ray


@pytest.fixture(scope="module")
def grid():
    return load_assembly(ASSEMBLIES / "grid.json")


def test_score_input_order_and_seeds(ray_local, grid):
    from rap.farm.pool import SimPool

    ops = standin.operations(grid)[:10]
    ops = ops + ops[:2]  # repeats get the same result
    params = SimParams(trials=4)
    with SimPool(2, backend=REAL, batch_size=3) as pool:
        res = pool.score(grid, ops, params, root_seed=7)
    assert [r.operation for r in res] == ops
    assert res[10] == res[0] and res[11] == res[1]
    from rap.sim.simulator import simulate

    fp = params.fingerprint()
    for op, r in zip(ops[:3], res[:3]):  # equals a direct in-process run with the derived seed
        assert r.key == label_key(op, grid.geometry_hash, fp, 7)
        assert r.seed == label_seed(op, grid.geometry_hash, fp, 7)
        direct = simulate(grid, op, params, np.random.default_rng(r.seed))
        assert (r.successes, r.trials, r.score) == (direct.successes, direct.trials, direct.score)


def test_scores_do_not_depend_on_workers_or_batches(ray_local, grid):
    from rap.farm.pool import SimPool

    ops = standin.operations(grid)[:12]
    params = SimParams(trials=4)
    with SimPool(1, backend=REAL, batch_size=5) as pool:
        one = [(r.key, r.successes) for r in pool.score(grid, ops, params, 3)]
    with SimPool(2, backend=REAL) as pool:  # adaptive batches, two workers
        two = [(r.key, r.successes) for r in pool.score(grid, ops, params, 3)]
    assert one == two
    with SimPool(2, backend=REAL) as pool:  # another root seed: other seeds
        other = pool.score(grid, ops[:2], params, 4)
    assert other[0].key != one[0][0]


def test_stream_bounded_in_flight_and_lazy_input(ray_local, grid):
    from rap.farm.pool import SimPool

    params = SimParams(trials=2)
    pulled = []

    def jobs():
        for j in SimPool.jobs(grid, standin.operations(grid), params, 1):
            pulled.append(j.key)
            yield j

    with SimPool(2, backend=FAKE, batch_size=2, per_worker_in_flight=2) as pool:
        seen = 0
        for res in pool.stream(jobs(), params, images=True):
            assert sum(pool._load) <= 4  # at most workers x per_worker_in_flight tasks
            if seen == 0:  # first result: at most cap batches (+1 look-ahead job) were pulled
                assert len(pulled) <= 4 * 2 + 1
            seen += len(res.rows)
            assert all(len(r["image"]) == 2 * 64 * 64 for r in res.rows)
        assert seen == len(standin.operations(grid))
        assert len(pool._refs) == 1  # the assembly was put once


@pytest.mark.parametrize("ray_retries", [True, False], ids=["ray-restarts", "pool-resubmits"])
def test_worker_killed_mid_run(ray_local, grid, ray_retries):
    from rap.farm.pool import SimPool

    params = SimParams(trials=2)
    ops = standin.operations(grid) * 1
    opts = {} if ray_retries else {"max_restarts": 0, "max_task_retries": 0}
    with SimPool(2, backend=FAKE, batch_size=3, **opts) as pool:
        pids = [i["pid"] for i in pool.ready()]
        keys, killed = [], False
        for res in pool.stream(SimPool.jobs(grid, ops, params, 5), params, images=False):
            keys += [r["key"] for r in res.rows]
            if not killed:
                os.kill(pids[0], signal.SIGKILL)
                killed = True
        assert killed
        assert sorted(keys) == sorted(set(keys))  # exactly once
        assert len(keys) == len(ops)
        if not ray_retries:
            assert pool.stats["resubmitted"] >= 1


def test_workers_that_cannot_start_are_one_clear_error(ray_local):
    """An actor that needs more CPUs than the cluster has never starts: ready() says so in one
    line (FarmError, exit status 3) instead of Ray's timeout traceback."""
    from rap.farm.pool import FarmError, SimPool

    with SimPool(1, backend=FAKE, cpus_per_worker=1000.0) as pool:
        with pytest.raises(FarmError, match="1 of 1 simulation workers did not start within 1 s"):
            pool.ready(timeout_s=1.0)
        assert FarmError.exit_code == 3


def test_elastic_start_on_what_runs_and_pending_actors_wait(ray_local, grid):
    """Three actors asked for on two CPUs: labelling starts on the first one, the third stays a
    pending demand (what the autoscaler sees) and never blocks the run."""
    from rap.farm.pool import SimPool

    params = SimParams(trials=2)
    ops = standin.operations(grid)
    with SimPool(3, backend=FAKE, batch_size=2) as pool:
        assert len(pool.ready(timeout_s=60, at_least=1)) >= 1
        keys = [r["key"] for res in pool.stream(SimPool.jobs(grid, ops, params, 5), params,
                                                images=False) for r in res.rows]
        assert sorted(keys) == sorted(set(keys)) and len(keys) == len(ops)
        pool.ready(timeout_s=60, at_least=2)
        assert pool.size == 3 and pool.started == 2  # the third is still pending


def test_idle_actors_are_released_and_the_pool_grows_again(ray_local, grid):
    """``workers=None``: one actor per CPU; released when idle, then as many again as CPUs are
    free when work comes."""
    from rap.farm.pool import SimPool

    params = SimParams(trials=2)
    ops = standin.operations(grid)[:8]
    with SimPool(None, backend=FAKE, idle_timeout_s=0.5) as pool:
        assert pool.size == 2  # ray_local's two CPUs
        first = {r["key"]: r["successes"] for res in pool.stream(
            SimPool.jobs(grid, ops, params, 5), params, images=False) for r in res.rows}
        deadline = time.monotonic() + 60
        while pool.size and time.monotonic() < deadline:
            time.sleep(0.1)
        assert pool.size == 0 and pool.stats["retired"] == 2  # both released, nothing pending
        import ray  # the released CPUs reach available_resources() a moment after the kill
        while ray.available_resources().get("CPU", 0) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        again = {r["key"]: r["successes"] for res in pool.stream(
            SimPool.jobs(grid, ops, params, 5), params, images=False) for r in res.rows}
        assert again == first and pool.stats["actors"] == 4  # two more, for the free CPUs


def test_no_worker_for_stall_timeout_is_one_clear_error(ray_local, grid):
    from rap.farm.pool import FarmError, SimPool

    params = SimParams(trials=2)
    with SimPool(1, backend=FAKE, cpus_per_worker=1000.0, stall_timeout_s=1.0) as pool:
        with pytest.raises(FarmError, match="no simulation worker has been running for 1 s"):
            list(pool.stream(SimPool.jobs(grid, standin.operations(grid)[:2], params, 5), params))


def test_a_failing_warm_up_fails_the_first_batch_in_one_line(ray_local, grid):
    """The warm-up runs on a thread of the actor (it answers its probe at once); its error comes
    back with the first task."""
    from rap.farm.actors import Backend
    from rap.farm.pool import FarmError, SimPool

    params = SimParams(trials=2)
    broken = Backend(simulate=FAKE.simulate, render=FAKE.render,
                     warm_up="tests.farm.standin:nothing")
    with SimPool(1, backend=broken) as pool:
        pool.ready(timeout_s=60)
        with pytest.raises(FarmError, match="has no attribute 'nothing'"):
            list(pool.stream(SimPool.jobs(grid, standin.operations(grid)[:2], params, 5), params))


def test_batches_grow_with_the_pool_so_the_task_rate_stays_bounded(ray_local):
    """A task runs target_task_s, or started / TASK_RATE seconds on a large pool (the driver's
    cost is per task), up to max_batch operations; the last wave still splits evenly."""
    from rap.farm.pool import TASK_RATE, SimPool

    with SimPool(1, backend=FAKE, target_task_s=1.0, max_batch=64) as pool:
        pool._per_op_s = 0.1  # the real simulator's ~9 operations a second
        sizes = {}
        for started in (1, 2, 100, 500, 5000):
            pool._started = started
            sizes[started] = pool._batch_len(None)
        pool._started = 500
        last_wave = pool._batch_len(1000)
        pool._started = 0
    assert TASK_RATE == 100.0
    assert sizes == {1: 10, 2: 10, 100: 10, 500: 50, 5000: 64}
    assert last_wave == 2  # 1,000 operations left over 500 actors


def test_tolerances_on_the_pool_are_the_ones_computed_here(ray_local):
    """Steps' simulated tolerances (rap.execution.tolerance) as pool tasks, one a step, in the
    jobs' order: the numbers of the same calls in this process (what the service's requests
    used to run in their own thread)."""
    from fractions import Fraction

    from rap.execution.tolerance import ToleranceRunner, tolerance
    from rap.farm.pool import SimPool
    from rap.farm.rollouts import PoolRollouts
    from rap.sim.params import DEFAULT_PARAMS

    from tests.execution.cases import slot

    asm, op = slot(Fraction(1, 4))
    jobs = [(asm, op, DEFAULT_PARAMS, mm, 3, "slot", False) for mm in (1.0, 0.5)]
    here = [tolerance(*job) for job in jobs]
    with SimPool(2, backend=REAL) as pool:
        runner = PoolRollouts(pool)
        assert isinstance(runner, ToleranceRunner)
        assert runner.run_tolerances(jobs) == here and runner.run_tolerances([]) == []
    assert here[0] != here[1]  # two different jobs, in their order


def test_perturbed_successes_on_the_pool_are_the_ones_computed_here(ray_local):
    """Operations simulated once from perturbed starts (rap.execution.perturbed) as pool tasks of
    ``PERTURBED_BATCH`` operations, in the jobs' order: the counts of the same calls here."""
    from rap.execution.error_model import ErrorModel
    from rap.execution.perturbed import PerturbedRunner, perturbed_successes
    from rap.farm.pool import SimPool
    from rap.farm.rollouts import PERTURBED_BATCH, PoolRollouts
    from rap.io import load_assembly
    from rap.plan.graph import reachable
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    problem = PlanningProblem(load_assembly(ASSEMBLIES / "cells" / "arch.json"), SimParams(trials=10),
                              3)
    ops = [op for c in reachable(problem).values() for op in c if not problem.is_free(op)]
    jobs = [(problem.assembly, op, problem.params, ErrorModel(), 2.0, problem.seed(op))
            for op in ops[:PERTURBED_BATCH + 3]]  # two tasks, the second not full
    here = [perturbed_successes(*job) for job in jobs]
    with SimPool(2, backend=REAL) as pool:
        runner = PoolRollouts(pool)
        assert isinstance(runner, PerturbedRunner)
        assert runner.run_perturbed(jobs) == here and runner.run_perturbed([]) == []
    assert len(set(here)) > 1  # not one count for every job


def test_rollouts_on_the_pool_are_the_same_on_one_worker_and_two(ray_local):
    """Whole-plan rollouts (rap.execution) as pool tasks: chunk results depend on the seed and
    the indices only, whichever worker ran them and in whatever order."""
    from rap.execution.error_model import DEFAULT_ERRORS
    from rap.execution.rollout import RolloutPlan
    from rap.execution.sequence import InProcess, measure
    from rap.farm.pool import SimPool
    from rap.farm.rollouts import PoolRollouts
    from rap.sim.params import DEFAULT_PARAMS

    from tests.execution.cases import wall_prefix

    asm, steps = wall_prefix(3)
    plan = RolloutPlan(steps, DEFAULT_PARAMS, DEFAULT_ERRORS, 2.0)
    here = measure(asm, plan, InProcess(), 4, rollouts=60)
    seen = []
    for workers in (1, 2):
        with SimPool(workers, backend=REAL) as pool:
            runner = PoolRollouts(pool, on_chunk=lambda d, t: seen.append((d, t)))
            out = measure(asm, plan, runner, 4, rollouts=60)
        assert out.success == here.success and out.step_failed == here.step_failed
    assert seen[-1] == (3, 3)  # progress: three chunks of 25, 25 and 10
