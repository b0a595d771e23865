"""rap.stats: the binomial tail against the exact sum, the union bound, and the one tail both
engines share (numpy here, torch in rap.model.network.heads)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rap.stats import binomial_tail, bonferroni, check_level, high_count, tail_at_least


def exact_tail(p: float, n: int, k: int) -> float:
    return sum(math.comb(n, j) * p ** j * (1 - p) ** (n - j) for j in range(k, n + 1))


@pytest.mark.parametrize("n, k", [(10, 0), (10, 7), (100, 95), (20, 21)])
def test_binomial_tail_is_the_exact_sum(n, k):
    ps = np.array([0.0, 0.05, 0.5, 0.93, 1.0])
    got = binomial_tail(ps, n, k)
    want = [exact_tail(min(max(p, 1e-12), 1 - 1e-12), n, k) if 0 < k <= n else float(k <= 0)
            for p in ps]
    assert got == pytest.approx(want, abs=1e-9)
    tail = tail_at_least(min(k, n), n)
    assert [tail(p) for p in ps[1:-1]] == pytest.approx(
        [exact_tail(p, n, min(k, n)) for p in ps[1:-1]], abs=1e-12)


def test_the_torch_head_uses_the_same_tail():
    torch = pytest.importorskip("torch")
    from rap.model.network import heads

    ps = np.linspace(0.01, 0.99, 9)
    assert heads.binomial_tail(torch.tensor(ps), 100, 95).numpy() == pytest.approx(
        binomial_tail(ps, 100, 95), abs=1e-9)


def test_high_count_bonferroni_and_levels():
    assert high_count(0.95, 100) == 95 and high_count(0.9, 10) == 9 and high_count(0.0, 5) == 0
    assert bonferroni(0.95, 10) == pytest.approx(0.995) and bonferroni(0.95, 0) == 0.95
    for bad in (0.0, 1.5, -1):
        with pytest.raises(ValueError):
            check_level(bad)


def test_expected_attempts_of_a_retried_step():
    from rap.stats import expected_attempts

    assert (expected_attempts(1.0), expected_attempts(0.5), expected_attempts(0.8)) == (1.0, 2.0,
                                                                                       1.25)
    assert expected_attempts(0.0) == math.inf  # never succeeds
