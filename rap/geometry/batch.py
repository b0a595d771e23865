"""Exact predicates over many segments at once: a floating-point filter with an exact fallback.

The exact layer's coordinates are integers of at most 51 bits (``rap.assembly.LIMITS`` scaled by
``rap.geometry.exact.to_integers``: ``|x| <= 10^15 < 2^53``), so every coordinate and every
difference of two is an exact float64. An orientation ``(b - a) x (c - a)`` computed in float64 is
then off by at most ``ERRBOUND * (|l| + |r|)`` (``l``, ``r`` its two products; Shewchuk's
``ccwerrboundA``, which also covers rounded differences): where the computed value is farther from
zero than that, its sign is the exact sign. Only the pairs where some sign is not certain (zero or
nearly so: touching, collinear, self-touching vertices) are decided by the exact integer predicate
``rap.geometry.validation.segments_intersect``. The answer is exact either way; the filter only
moves the common case into numpy. This is the filtered-kernel idea of CGAL and Shewchuk's
adaptive predicates, at its first stage.

``box_pairs(boxes)`` lists the pairs of closed boxes that meet (a sweep on x in numpy, in chunks
of bounded memory); ``crossing_signs`` classifies candidate segment pairs. Cost: O(n log n + k)
numpy work for n boxes and k overlapping pairs (k is O(n^2) at worst, e.g. the spikes of a star),
at about 10^7 pairs per second, plus one Python-level exact test per undecided pair.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

__all__ = ["ERRBOUND", "MAX_EXACT_FLOAT_INT", "box_pairs", "orient_signs", "crossing_signs"]

_EPS = 2.0 ** -53
ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS  # Shewchuk's ccwerrboundA
MAX_EXACT_FLOAT_INT = 2 ** 53  # |coordinate| and |difference| below this are exact floats
_CHUNK_PAIRS = 1 << 21  # pairs materialised at once (~50 MB of index arrays)


def box_pairs(boxes: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Chunks ``(i, j)`` (int64 arrays, ``i < j`` not guaranteed, ``i != j``) of every pair of
    rows of ``boxes`` ``[n, 4] = (x0, y0, x1, y1)`` whose closed boxes meet; each pair once."""
    n = len(boxes)
    if n < 2:
        return
    order = np.argsort(boxes[:, 0], kind="stable")
    x0, y0, x1, y1 = (boxes[order, k] for k in range(4))
    # in x-sorted order, the partners of position p are the positions p+1 .. hi[p]-1 whose x0 is
    # at most x1[p]
    hi = np.searchsorted(x0, x1, side="right")
    counts = np.maximum(hi - np.arange(n) - 1, 0)
    start = 0
    while start < n:
        total = np.cumsum(counts[start:])
        stop = start + max(1, int(np.searchsorted(total, _CHUNK_PAIRS, side="right")))
        stop = min(stop, n)
        c = counts[start:stop]
        p = np.repeat(np.arange(start, stop), c)
        if len(p):
            offsets = np.arange(len(p)) - np.repeat(np.cumsum(c) - c, c)
            q = p + 1 + offsets
            keep = (y0[q] <= y1[p]) & (y0[p] <= y1[q])
            yield order[p[keep]], order[q[keep]]
        start = stop


def orient_signs(ax, ay, bx, by, cx, cy) -> tuple[np.ndarray, np.ndarray]:
    """Signs of the orientations ``(b - a) x (c - a)`` (float64 arrays of exact integers, see the
    module doc) and a mask of where each sign is certain (a zero is never certain)."""
    left = (bx - ax) * (cy - ay)
    right = (by - ay) * (cx - ax)
    det = left - right
    certain = np.abs(det) > ERRBOUND * (np.abs(left) + np.abs(right))
    return np.sign(det), certain


def crossing_signs(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """For segment pairs ``ab``, ``cd`` (float64 arrays ``[k, 2]`` of exact integers): a mask of
    the pairs certain to cross at one interior point of both, and a mask of the pairs the filter
    cannot decide (to be tested exactly). Pairs in neither mask are certainly disjoint."""
    d1, c1 = orient_signs(c[:, 0], c[:, 1], d[:, 0], d[:, 1], a[:, 0], a[:, 1])
    d2, c2 = orient_signs(c[:, 0], c[:, 1], d[:, 0], d[:, 1], b[:, 0], b[:, 1])
    d3, c3 = orient_signs(a[:, 0], a[:, 1], b[:, 0], b[:, 1], c[:, 0], c[:, 1])
    d4, c4 = orient_signs(a[:, 0], a[:, 1], b[:, 0], b[:, 1], d[:, 0], d[:, 1])
    # a certain separation on either side decides "disjoint" even if the other side is unsure
    apart = (c1 & c2 & (d1 == d2)) | (c3 & c4 & (d3 == d4))
    certain = c1 & c2 & c3 & c4
    crossing = certain & (d1 != d2) & (d3 != d4)
    return crossing, ~(apart | crossing)
