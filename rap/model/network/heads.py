"""What the network's outputs mean: the two heads, their losses, P(high) and the expected score.

* ``class`` head (the paper's): two logits (not high, high); loss: cross-entropy against the
  label ``score >= threshold``, optionally weighted by inverse class frequency; P(high) is the
  softmax probability of "high".
* ``binomial`` head: one logit z of the per-trial success probability p = sigmoid(z); loss: the
  binomial negative log-likelihood of the observed ``successes`` out of ``trials``, i.e. the label
  is the count, not only the class, so an operation scored 0.94 teaches that it is almost high.
  P(high) is the binomial tail ``P(Bin(n, p) >= k)``, k = ceil(threshold * n): the probability
  that a fresh run of n trials lands in the class "high", which is what a fresh label would say.
  The expected score is p itself, a calibrated number for planners that multiply scores.

A temperature T > 0 divides the logits before either link (``T = 1``: none); it is fitted on
held-out rows after training (``fit_temperature``) and stored in the checkpoint.

Torch and numpy versions compute the same quantities: torch for training, numpy for inference
paths that want no autograd. The binomial tail is an exact finite sum over j = k..n (at most
n - k + 1 terms; 6 for 100 trials and 0.95), computed in log space.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from rap.stats import high_count, log_comb

__all__ = ["HEADS", "out_features", "loss", "prob_high", "expected_score",
           "binomial_tail", "prob_high_np", "expected_score_np", "fit_temperature"]

HEADS = ("class", "binomial")


def out_features(head: str) -> int:
    if head not in HEADS:
        raise ValueError(f"head must be one of {HEADS}, not {head!r}")
    return 2 if head == "class" else 1


def binomial_tail(p: torch.Tensor, n: int, k: int) -> torch.Tensor:
    """P(Bin(n, p) >= k), elementwise, differentiable; exact sum in log space (the torch twin of
    ``rap.stats.binomial_tail``)."""
    if k <= 0:
        return torch.ones_like(p)
    if k > n:
        return torch.zeros_like(p)
    p = p.clamp(1e-12, 1 - 1e-12)
    lp, lq = torch.log(p), torch.log1p(-p)
    terms = torch.stack([log_comb(n, j) + j * lp + (n - j) * lq for j in range(k, n + 1)])
    return torch.logsumexp(terms, dim=0).exp().clamp(0.0, 1.0)


def loss(output: torch.Tensor, head: str, *, labels: torch.Tensor, successes: torch.Tensor,
         trials: torch.Tensor, class_weights: torch.Tensor | None = None) -> torch.Tensor:
    """Mean training loss of a batch (see the module docstring)."""
    if head == "class":
        return F.cross_entropy(output, labels, weight=class_weights)
    z = output[:, 0]
    s, n = successes.to(z.dtype), trials.to(z.dtype)
    # -log[p^s (1-p)^(n-s)] with p = sigmoid(z), stably: s softplus(-z) + (n - s) softplus(z)
    nll = s * F.softplus(-z) + (n - s) * F.softplus(z)
    return (nll / n).mean()


def prob_high(output: torch.Tensor, head: str, threshold: float, trials: int,
              temperature: float = 1.0) -> torch.Tensor:
    """P(high) of each row from the network's output (torch)."""
    if head == "class":
        return torch.softmax(output.float() / temperature, dim=1)[:, 1]
    p = torch.sigmoid(output[:, 0].double() / temperature)
    return binomial_tail(p, trials, high_count(threshold, trials)).float()


def expected_score(output: torch.Tensor, head: str, temperature: float = 1.0) -> torch.Tensor:
    """The expected success rate of each row: p for the binomial head; for the class head only
    P(high) is known, which is returned as the best available proxy."""
    if head == "class":
        return torch.softmax(output.float() / temperature, dim=1)[:, 1]
    return torch.sigmoid(output[:, 0].float() / temperature)


def prob_high_np(output: np.ndarray, head: str, threshold: float, trials: int,
                 temperature: float = 1.0) -> np.ndarray:
    """``prob_high`` on a numpy array of outputs (float64 result)."""
    return prob_high(torch.from_numpy(np.asarray(output)), head, threshold, trials,
                     temperature).double().numpy()


def expected_score_np(output: np.ndarray, head: str, temperature: float = 1.0) -> np.ndarray:
    return expected_score(torch.from_numpy(np.asarray(output)), head, temperature).double().numpy()


def fit_temperature(output: np.ndarray, head: str, labels: np.ndarray, threshold: float,
                    trials: int, grid: np.ndarray | None = None) -> float:
    """The temperature minimising the log loss of P(high) against ``labels`` (0/1) on held-out
    rows: a 1-D search over a log grid (0.25..8), then a local refinement. O(grid x rows)."""
    labels = np.asarray(labels, dtype=np.float64)
    if len(labels) == 0 or labels.min() == labels.max():
        return 1.0
    out = torch.from_numpy(np.asarray(output, dtype=np.float64))

    def nll(t: float) -> float:
        q = prob_high(out, head, threshold, trials, t).double().numpy().clip(1e-7, 1 - 1e-7)
        return float(-(labels * np.log(q) + (1 - labels) * np.log(1 - q)).mean())

    grid = np.exp(np.linspace(np.log(0.25), np.log(8.0), 41)) if grid is None else grid
    best = min(grid, key=nll)
    fine = best * np.exp(np.linspace(-0.09, 0.09, 19))
    return float(min(fine, key=nll))
