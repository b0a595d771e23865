"""Whole-plan rollouts: seeded per rollout and step, independent of how the chunks are run, and
with errors and carrying off, the product of the steps' success rates."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rap.execution.error_model import DEFAULT_ERRORS, ErrorModel
from rap.execution.rollout import CHUNK, RolloutPlan, chunks, run_chunk, run_chunks
from rap.execution.sequence import InProcess, measure
from rap.sim.params import DEFAULT_PARAMS
from rap.sim.simulator import simulate

from tests.execution.cases import wall_prefix


def test_chunks_cover_the_rollouts_from_a_chunk_boundary():
    assert chunks(0, 60) == [(0, CHUNK), (CHUNK, CHUNK), (2 * CHUNK, 60 - 2 * CHUNK)]
    assert chunks(100, 100) == []


def test_a_chunk_is_reproducible_and_independent_of_its_neighbours():
    asm, steps = wall_prefix(3)
    plan = RolloutPlan(steps, DEFAULT_PARAMS, DEFAULT_ERRORS, 2.0)
    both = run_chunks(asm, plan, 5, [(0, CHUNK), (CHUNK, 10)])
    alone = run_chunk(asm, plan, 5, CHUNK, 10)
    assert both[1].failed_at == alone.failed_at and both[1].first == CHUNK
    assert run_chunk(asm, plan, 5, 0, CHUNK).failed_at == both[0].failed_at
    assert run_chunk(asm, plan, 6, 0, CHUNK).failed_at != both[0].failed_at  # the seed counts


def test_the_local_workers_measure_what_one_process_does():
    from rap.plan.scoring.local_simulator import LocalSimulator

    asm, steps = wall_prefix(3)
    plan = RolloutPlan(steps, DEFAULT_PARAMS, DEFAULT_ERRORS, 2.0)
    here = measure(asm, plan, InProcess(), 9, rollouts=75)
    sim = LocalSimulator(processes=2)
    try:
        there = measure(asm, plan, sim, 9, rollouts=75)
    finally:
        sim.close()
    assert here.success == there.success and here.step_failed == there.step_failed


def test_without_errors_or_carrying_a_rollout_succeeds_with_the_product_of_the_steps():
    asm, steps = wall_prefix(6)
    n = 200
    params = replace(DEFAULT_PARAMS, trials=n)
    product = float(np.prod([simulate(asm, op, params, np.random.default_rng([3, k])).score
                             for k, op in enumerate(steps)]))
    plan = RolloutPlan(steps, DEFAULT_PARAMS, ErrorModel.zero(), 2.0, carry=False)
    out = measure(asm, plan, InProcess(), 3, rollouts=n)
    assert 0.3 < product < 0.8  # a plan whose steps fail now and then
    assert out.success.low <= product <= out.success.high
    assert out.step_tried[0] == n and out.success.successes == n - sum(out.step_failed)
    assert all(t - f == nxt for t, f, nxt in zip(out.step_tried, out.step_failed,
                                                  out.step_tried[1:]))


def test_errors_far_beyond_the_tolerance_make_the_plan_fail():
    asm, steps = wall_prefix(2)
    huge = ErrorModel(grasp_across_mm=40.0, grasp_along_mm=40.0, grasp_angle_deg=10.0,
                      repeatability_mm=0.0)
    out = run_chunk(asm, RolloutPlan(steps, DEFAULT_PARAMS, huge, 2.0), 1, 0, 20)
    assert all(f == 0 for f in out.failed_at)
