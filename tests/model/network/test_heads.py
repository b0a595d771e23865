"""rap.model.network.heads: the binomial head's likelihood and tail, the class head, temperature fitting."""

import math

import numpy as np
import pytest
import torch

from rap.model.network import heads
from rap.stats import high_count


def test_binomial_tail_is_the_exact_sum():
    p = torch.tensor([0.0, 0.5, 0.9, 0.95, 0.99, 1.0], dtype=torch.float64)
    got = heads.binomial_tail(p, 100, 95).numpy()
    ref = [sum(math.comb(100, j) * q ** j * (1 - q) ** (100 - j) for j in range(95, 101))
           for q in p.tolist()]
    np.testing.assert_allclose(got, ref, atol=1e-9)
    assert high_count(0.95, 100) == 95 and high_count(0.95, 20) == 19


def test_binomial_loss_is_the_negative_log_likelihood_per_trial():
    z = torch.tensor([[0.3], [-1.2], [4.0]], dtype=torch.float64, requires_grad=True)
    s, n = torch.tensor([3, 0, 10]), torch.tensor([10, 10, 10])
    got = heads.loss(z, "binomial", labels=torch.zeros(3, dtype=torch.long), successes=s, trials=n)
    p = torch.sigmoid(z[:, 0])
    ref = -(s * torch.log(p) + (n - s) * torch.log(1 - p)) / n
    assert got.item() == pytest.approx(ref.mean().item())
    got.backward()
    assert torch.isfinite(z.grad).all()


def test_prob_high_and_expected_score_per_head():
    out2 = torch.tensor([[0.0, 2.0], [1.0, -1.0]])
    ph = heads.prob_high(out2, "class", 0.95, 100)
    np.testing.assert_allclose(ph.numpy(), torch.softmax(out2, 1)[:, 1].numpy(), rtol=1e-6)
    z = torch.tensor([[5.0], [0.0]])
    p = torch.sigmoid(z[:, 0])
    assert heads.expected_score(z, "binomial").numpy() == pytest.approx(p.numpy())
    tail = heads.prob_high(z, "binomial", 0.95, 100)
    assert tail[0] > 0.5 > tail[1]  # p = 0.993 is likely high, p = 0.5 never
    assert heads.prob_high(z, "binomial", 0.95, 100, temperature=4.0)[0] < tail[0]
    assert heads.out_features("class") == 2 and heads.out_features("binomial") == 1


def test_fit_temperature_undoes_a_scaled_logit():
    rng = np.random.default_rng(0)
    true = rng.normal(0, 2, size=4000)
    labels = (rng.random(4000) < 1 / (1 + np.exp(-true))).astype(int)
    logits = np.stack([np.zeros_like(true), 3.0 * true], axis=1)  # over-confident by 3x
    t = heads.fit_temperature(logits, "class", labels, 0.95, 100)
    assert 2.4 < t < 3.6
