"""Classification metrics of the robustness CNN and the calibration of its confidence.

Labels: 1 high, 0 not high. ``prob_high`` is the softmax probability of "high" — the confidence the
planner ranks by; the predicted class is "high" where ``prob_high >= 0.5``.

Calibration: the rows are binned by ``prob_high`` into ``RELIABILITY_BINS`` equal bins; per bin the
mean predicted probability and the observed fraction of high rows (reliability table). The
expected calibration error is the row-weighted mean of their absolute difference. Bins are kept as
sums so that folds can be pooled (``pool_reliability``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["RELIABILITY_BINS", "classification_metrics", "reliability_sums", "pool_reliability",
           "reliability_table", "expected_calibration_error"]

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


def classification_metrics(labels: np.ndarray, prob_high: np.ndarray) -> dict:
    """Accuracy overall, on not-high rows (low) and on high rows (high); class counts; ECE and
    the reliability sums. Empty classes give NaN accuracies."""
    labels = np.asarray(labels, dtype=np.int64)
    prob_high = np.asarray(prob_high, dtype=np.float64)
    hit = (prob_high >= 0.5).astype(np.int64) == labels
    rel = reliability_sums(labels, prob_high)
    return {"rows": int(len(labels)), "high_rows": int(labels.sum()),
            "accuracy": _rate(hit), "low_accuracy": _rate(hit[labels == 0]),
            "high_accuracy": _rate(hit[labels == 1]),
            "ece": expected_calibration_error(rel), "reliability": rel}
