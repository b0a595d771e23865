"""Confidence intervals of step scores and of R (rap.plan.report.intervals), checked against closed
forms, an independent binomial tail, and their coverage on known rates (seeded simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.plan.report.intervals import LEVEL, robustness_interval, step_interval
from rap.stats import clopper_pearson, successes_of


def tail_at_least(k: int, n: int, p: float) -> float:
    """P(X >= k), X ~ Binomial(n, p), by the plain sum (an independent check)."""
    return sum(math.comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k, n + 1))


@pytest.mark.parametrize("n", [1, 10, 100])
def test_all_or_nothing_bounds_have_closed_forms(n):
    assert clopper_pearson(0, n) == (0.0, pytest.approx(1 - 0.025 ** (1 / n), abs=1e-12))
    assert clopper_pearson(n, n) == (pytest.approx(0.025 ** (1 / n), abs=1e-12), 1.0)


@pytest.mark.parametrize("k,n", [(1, 10), (5, 10), (83, 100), (95, 100), (99, 100), (17, 40)])
def test_bounds_solve_the_tail_equations(k, n):
    lo, hi = clopper_pearson(k, n)
    assert lo < k / n < hi
    assert tail_at_least(k, n, lo) == pytest.approx(0.025, abs=1e-9)
    assert 1 - tail_at_least(k + 1, n, hi) == pytest.approx(0.025, abs=1e-9)
    lo2, hi2 = clopper_pearson(n - k, n)  # symmetry of failures and successes
    assert (lo2, hi2) == (pytest.approx(1 - hi, abs=1e-12), pytest.approx(1 - lo, abs=1e-12))
    wide_lo, wide_hi = clopper_pearson(k, n, 0.99)
    assert wide_lo < lo and hi < wide_hi


def test_step_interval_reads_the_score_as_successes_over_trials():
    assert successes_of(0.83, 100) == 83 and successes_of(0.7, 10) == 7
    assert step_interval(0.83, 100) == clopper_pearson(83, 100)
    assert step_interval(None, 100) is None and step_interval(0.5, None) is None
    with pytest.raises(ValueError):
        successes_of(1.5, 10)
    with pytest.raises(ValueError):
        clopper_pearson(11, 10)


def test_r_interval_is_the_product_of_bonferroni_bounds():
    scores = [0.9, 1.0, 0.75]
    lo, hi = robustness_interval(scores, 20)
    each = [clopper_pearson(successes_of(s, 20), 20, 1 - 0.05 / 3) for s in scores]
    assert lo == pytest.approx(math.prod(a for a, _ in each))
    assert hi == pytest.approx(math.prod(b for _, b in each))
    assert lo < math.prod(scores) < hi
    assert robustness_interval([], 20) == (1.0, 1.0)
    assert robustness_interval([0.5, None], 20) is None and robustness_interval([0.5], None) is None


def _slack(draws: int) -> float:
    """Three standard errors of a coverage estimate at 95 %."""
    return 3 * math.sqrt(LEVEL * (1 - LEVEL) / draws)


@pytest.mark.parametrize("p", [0.3, 0.8, 0.95, 0.99])
def test_step_intervals_cover_a_known_rate(p):
    n, draws = 50, 4000
    rng = np.random.default_rng(20261125)
    table = [clopper_pearson(k, n) for k in range(n + 1)]
    ks = rng.binomial(n, p, size=draws)
    covered = np.mean([table[k][0] <= p <= table[k][1] for k in ks])
    assert covered >= LEVEL - _slack(draws)


@pytest.mark.parametrize("ps", [(0.9, 0.97, 0.8, 1.0, 0.99), (0.5, 0.6), (0.99,) * 8])
def test_r_intervals_cover_a_known_product(ps):
    n, draws = 30, 2000
    rng = np.random.default_rng(7)
    r = math.prod(ps)
    each = 1 - (1 - LEVEL) / len(ps)
    table = [clopper_pearson(k, n, each) for k in range(n + 1)]
    hits = 0
    for i in range(draws):
        ks = rng.binomial(n, ps)
        lo = math.prod(table[k][0] for k in ks)
        hi = math.prod(table[k][1] for k in ks)
        if i < 20:  # the library's interval is this one (checked on a few draws: speed)
            assert (lo, hi) == pytest.approx(robustness_interval([k / n for k in ks], n))
        hits += lo <= r <= hi
    assert hits / draws >= LEVEL - _slack(draws)
