"""Classification metrics of the robustness CNN and the calibration of its confidence.

Labels: 1 high, 0 not high. ``prob_high`` is the softmax probability of "high" — the confidence the
planner ranks by; the predicted class is "high" where ``prob_high >= 0.5``.

Calibration: the rows are binned by ``prob_high`` into ``RELIABILITY_BINS`` equal bins; per bin the
mean predicted probability and the observed fraction of high rows (reliability table). The
expected calibration error is the row-weighted mean of their absolute difference. Bins are kept as
sums so that folds can be pooled (``pool_reliability``).

Noise ceiling (``noise_ceiling``): a label is one draw of ``n`` noisy trials, so an operation
whose success rate is near the threshold lands in either class almost at random, and no model can
agree with such labels every time. The ceiling is the expected agreement between a fresh label and
the best possible prediction, one that knows each operation's true success rate p and predicts
"high" iff P(Bin(n, p) >= k) >= 1/2: per row, E[max(q(p), 1 - q(p))] with q(p) = P(Bin(n, p) >= k)
and p under the posterior Beta(s + 1, n - s + 1) of the row's s successes (uniform prior), by
quadrature on a grid of p. Rows share the value of their (s, n), so the cost is O(distinct counts
x grid), not O(rows).
"""

from __future__ import annotations

import math

import numpy as np

from rap.stats import binomial_tail

__all__ = ["RELIABILITY_BINS", "classification_metrics", "reliability_sums", "pool_reliability",
           "reliability_table", "expected_calibration_error", "noise_ceiling"]

RELIABILITY_BINS = 10


def _rate(hits: np.ndarray) -> float:
    return float(hits.mean()) if len(hits) else math.nan


def reliability_sums(labels: np.ndarray, prob_high: np.ndarray, bins: int = RELIABILITY_BINS) -> dict:
    """Per-bin counts, sums of predicted P(high) and of high labels (plain lists)."""
    b = np.minimum((np.asarray(prob_high) * bins).astype(np.int64), bins - 1)
    return {"bins": bins,
            "count": np.bincount(b, minlength=bins).tolist(),
            "sum_prob": np.bincount(b, weights=prob_high, minlength=bins).tolist(),
            "sum_high": np.bincount(b, weights=labels.astype(float), minlength=bins).tolist()}


def pool_reliability(parts: list[dict]) -> dict:
    """Sum of several ``reliability_sums`` (same number of bins)."""
    bins = parts[0]["bins"]
    out = {"bins": bins, "count": [0] * bins, "sum_prob": [0.0] * bins, "sum_high": [0.0] * bins}
    for p in parts:
        for k in ("count", "sum_prob", "sum_high"):
            out[k] = [a + b for a, b in zip(out[k], p[k])]
    return out


def reliability_table(sums: dict) -> list[dict]:
    """Rows: bin range, rows, mean predicted P(high), observed fraction high."""
    bins = sums["bins"]
    rows = []
    for i in range(bins):
        n = sums["count"][i]
        rows.append({"lo": i / bins, "hi": (i + 1) / bins, "rows": int(n),
                     "mean_prob_high": sums["sum_prob"][i] / n if n else math.nan,
                     "frac_high": sums["sum_high"][i] / n if n else math.nan})
    return rows


def expected_calibration_error(sums: dict) -> float:
    total = sum(sums["count"])
    if not total:
        return math.nan
    return float(sum(abs(p - h) for p, h in zip(sums["sum_prob"], sums["sum_high"])) / total)


_GRID = np.linspace(0.0, 1.0, 4001)[1:-1]


def _agreement(p: np.ndarray, n: int, k: int) -> np.ndarray:
    """max(q, 1 - q) with q = P(Bin(n, p) >= k), for an array of p (exact finite sum)."""
    q = binomial_tail(p, n, k)  # 1 or 0 outside 1 <= k <= n: agreement 1 either way
    return np.maximum(q, 1.0 - q)


def noise_ceiling(successes: np.ndarray, trials: np.ndarray, threshold: float) -> float:
    """The expected agreement of the best possible prediction with fresh labels (module doc)."""
    successes = np.asarray(successes, dtype=np.int64)
    trials = np.asarray(trials, dtype=np.int64)
    if len(successes) == 0:
        return math.nan
    total = 0.0
    pairs, counts = np.unique(np.stack([successes, trials]), axis=1, return_counts=True)
    for (s, n), c in zip(pairs.T, counts):
        k = max(0, math.ceil(threshold * n - 1e-9))
        logw = s * np.log(_GRID) + (n - s) * np.log1p(-_GRID)
        w = np.exp(logw - logw.max())
        total += c * float((w * _agreement(_GRID, int(n), k)).sum() / w.sum())
    return total / len(successes)


def classification_metrics(labels: np.ndarray, prob_high: np.ndarray,
                           successes: np.ndarray | None = None, trials: np.ndarray | None = None,
                           threshold: float = 0.95, reliability: bool = True) -> dict:
    """Accuracy overall, on not-high rows (low) and on high rows (high); class counts; ECE and
    the reliability sums; with ``successes`` and ``trials`` the noise ceiling too. Empty classes
    give NaN accuracies."""
    labels = np.asarray(labels, dtype=np.int64)
    prob_high = np.asarray(prob_high, dtype=np.float64)
    hit = (prob_high >= 0.5).astype(np.int64) == labels
    rel = reliability_sums(labels, prob_high)
    out = {"rows": int(len(labels)), "high_rows": int(labels.sum()),
           "accuracy": _rate(hit), "low_accuracy": _rate(hit[labels == 0]),
           "high_accuracy": _rate(hit[labels == 1]),
           "ece": expected_calibration_error(rel)}
    if reliability:
        out["reliability"] = rel
    if successes is not None and trials is not None:
        out["ceiling"] = noise_ceiling(successes, trials, threshold)
    return out
