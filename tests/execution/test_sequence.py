"""Sequence success: waves of rollouts until the interval is narrow enough."""

from __future__ import annotations

from rap.execution.error_model import DEFAULT_ERRORS
from rap.execution.rollout import ChunkOutcome, RolloutPlan
from rap.execution.sequence import WAVES, measure, tally
from rap.sim.params import DEFAULT_PARAMS

from tests.execution.cases import wall_prefix


class Scripted:
    """A runner whose rollouts succeed with a given pattern (every k-th fails at step 0)."""

    def __init__(self, fail_every: int):
        self.fail_every, self.asked = fail_every, []

    def run_rollouts(self, assembly, plan, root_seed, work):
        self.asked.append(list(work))
        return [ChunkOutcome(f, tuple(0 if (f + i) % self.fail_every == 0 else -1
                                      for i in range(c))) for f, c in work]


def _plan():
    asm, steps = wall_prefix(2)
    return asm, RolloutPlan(steps, DEFAULT_PARAMS, DEFAULT_ERRORS, 2.0)


def test_a_sure_plan_stops_after_the_first_wave_an_even_one_goes_on():
    asm, plan = _plan()
    sure = measure(asm, plan, Scripted(fail_every=10 ** 6), 0)
    assert sure.rollouts == WAVES[0] and sure.success.half_width <= 0.05
    even = measure(asm, plan, Scripted(fail_every=2), 0)
    assert even.rollouts > 400 and even.success.half_width <= 0.05
    runner = Scripted(fail_every=2)
    measure(asm, plan, runner, 0)
    firsts = [f for wave in runner.asked for f, _ in wave]
    assert firsts == sorted(set(firsts))  # every rollout index once, in waves


def test_tally_counts_reached_and_failed_steps():
    wins, tried, failed, runs = tally(3, [ChunkOutcome(0, (-1, 0, 2, 1, -1))])
    assert (wins, runs) == (2, 5) and tried == [5, 4, 3] and failed == [1, 1, 1]
