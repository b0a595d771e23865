"""research.variants.sequential: Clopper-Pearson bounds, and the sequential test's error rate on synthetic
Bernoulli streams (seeded), whatever the thresholds at each look."""

from __future__ import annotations

import numpy as np
import pytest

from research.variants.sequential import (ABOVE, BELOW, UNDECIDED, SequentialTest, lower_bound,
                                upper_bound)

STREAMS = 2000


def test_clopper_pearson_bounds_in_closed_form_at_the_ends():
    # with no success, P(X <= 0) = (1 - p)^n = alpha gives the upper bound 1 - alpha^(1/n)
    for n, alpha in [(20, 0.01), (40, 0.05), (60, 1 / 120)]:
        assert upper_bound(0, n, alpha) == pytest.approx(1 - alpha ** (1 / n), abs=1e-12)
        assert lower_bound(n, n, alpha) == pytest.approx(alpha ** (1 / n), abs=1e-12)
    assert upper_bound(20, 20, 0.01) == 1.0 and lower_bound(0, 20, 0.01) == 0.0
    for s in range(21):  # ordered, around the estimate
        assert lower_bound(s, 20, 0.01) <= s / 20 <= upper_bound(s, 20, 0.01)
    with pytest.raises(ValueError):
        upper_bound(21, 20, 0.01)


def _run(test: SequentialTest, p: float, taus, rng) -> str:
    """One stream: chunks of Bernoulli(p) trials, a look after each against ``taus[look]``,
    stopped at the first decision (what ``research.variants.screening`` does)."""
    s = n = 0
    for chunk, tau in zip(test.chunks, taus):
        s += int(rng.binomial(chunk, p))
        n += chunk
        got = test.decide(s, n, tau)
        if got != UNDECIDED:
            return got
    return UNDECIDED


@pytest.mark.parametrize("chunks", [(10,), (20, 20, 20)])
@pytest.mark.parametrize("delta", [0.05, 0.2])
@pytest.mark.parametrize("tau", [0.3, 0.7, 0.9])
def test_wrong_decisions_at_most_delta(delta, tau, chunks):
    test = SequentialTest(delta, chunks)
    rng = np.random.default_rng(20190527)
    for p, wrong in [(min(1.0, tau + 0.1), {BELOW}), (tau - 0.1, {ABOVE}), (tau, {BELOW, ABOVE})]:
        got = [_run(test, p, [tau] * 3, rng) for _ in range(STREAMS)]
        errors = sum(g in wrong for g in got) / STREAMS
        assert errors <= delta, (p, tau, errors)
    # and it decides: far below tau, most streams are shown below
    if tau >= 0.7:
        far = [_run(test, tau - 0.5, [tau] * 3, rng) for _ in range(200)]
        assert far.count(BELOW) >= 160


def test_thresholds_that_change_between_looks_keep_the_error_rate():
    # the union bound does not involve the thresholds: each look may compare with another one,
    # here always just under the true rate (the hardest place for a wrong "below")
    test = SequentialTest(0.05, (20, 20, 20))
    rng = np.random.default_rng(7)
    for p in (0.5, 0.8, 0.95):
        got = [_run(test, p, [p - 0.01, p, p - 0.02], rng) for _ in range(STREAMS)]
        assert got.count(BELOW) / STREAMS <= 0.05


def test_the_test_looks_only_at_its_schedule():
    test = SequentialTest(0.05, (20, 20, 20))
    assert test.looks == (20, 40, 60) and test.alpha == pytest.approx(0.05 / 6)
    assert test.decide(0, 20, 0.5) == BELOW and test.decide(20, 20, 0.5) == ABOVE
    with pytest.raises(ValueError):
        test.decide(10, 30, 0.5)  # not a look: the error rate would not hold
    for bad in (dict(delta=0.0), dict(delta=1.0), dict(chunks=()), dict(chunks=(20, 0))):
        with pytest.raises(ValueError):
            SequentialTest(**bad)
