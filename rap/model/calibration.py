"""Upper bounds on an operation's simulated score from the model's expected score: split conformal.

The model's expected score ``p`` of an operation (the binomial head's success rate,
``rap.model.inference.operations.OperationPredictor.expected_score``) is a point estimate; a search that must know
how much better an unsimulated operation *could* be needs an upper bound ``u(p)`` on its
simulated score ``s`` with a stated coverage, ``P(s <= u(p)) >= level``.

``fit(predicted, simulated, bins=6)`` takes a calibration set (pairs of the model's ``p`` and the
simulator's ``s`` for operations of assemblies the model was not trained on), cuts ``p`` into
``bins`` bins at its quantiles, and keeps, per bin, the sorted residuals ``s - p`` (a *Mondrian*
split-conformal predictor: the bins let the width follow ``p``, e.g. narrow near 1 and 0).
``ScoreBounds.upper(p, level)`` is then ``min(1, p + q)``, ``q`` the ``ceil((n + 1) level)``-th
smallest of the ``n`` residuals of ``p``'s bin: for an operation exchangeable with the bin's
calibration operations, ``P(s <= upper) >= level`` (split conformal's finite-sample guarantee;
the bin edges come from the same data, a common approximation). A bin with too few residuals for
the level (``ceil((n + 1) level) > n``, i.e. ``n < level / (1 - level)``: 19 at 0.95, 199 at
0.995; every bin at level 1) bounds by 1, the trivial bound; ``min_count(level)`` says how many
are needed.

Special bounds: ``ScoreBounds.trivial()`` (no calibration: every operation bounded by 1; what
``load()`` gives when the shipped file is absent, with a note in ``provenance``) and
``ScoreBounds.zero_width()`` (a perfect scorer: ``upper(p) = p``). ``MeanBounds(a, b)``: for a
score that is the mean of two scorers' predictions, the larger of their *rising envelopes*
(``ScoreBounds.rising``) at half the miss rate each.

``to_json``/``from_json`` and ``save``/``load`` keep a fit in a file (``DEFAULT_PATH``,
``rap/data/score_bounds.json``: the shipped model's calibration), with ``provenance`` (the model's
name and fingerprint, the calibration set, counts, the date). Residuals are stored rounded *up*
to 1e-6 (never a narrower bound than fitted).

Cost: ``fit`` O(n log n); ``upper`` O(m log bins) for m scores. numpy only.

Example::

    bounds = fit(predicted, simulated, bins=6, provenance={"model": "default_model.pt"})
    bounds.upper(np.array([0.5, 0.97]), level=0.99)   # e.g. [0.81, 1.0]
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rap.stats import check_level

__all__ = ["ScoreBounds", "MeanBounds", "fit", "load", "save", "min_count", "DEFAULT_PATH",
           "DEFAULT_BINS", "FORMAT"]

DEFAULT_PATH = Path(__file__).resolve().parents[1] / "data" / "score_bounds.json"
DEFAULT_BINS = 6
FORMAT = "rap-farm score bounds"
_ROUND = 1e6  # residuals are stored rounded up to 1e-6


def _rank(n: int, level: float) -> int:
    """``ceil((n + 1) level)``, the conformal quantile's rank (1-based) among ``n`` residuals;
    the product is rounded to 9 decimals first so that 20 x 0.95 is 19, not 20."""
    return math.ceil(round((n + 1) * level, 9))


def min_count(level: float) -> int:
    """The fewest residuals a bin needs for a bound below 1 at ``level`` in (0, 1): the least
    ``n`` with ``ceil((n + 1) level) <= n``."""
    level = check_level(level)
    if level == 1.0:
        raise ValueError("level 1: no number of residuals bounds below 1")
    n = max(1, math.floor(level / (1.0 - level)) - 1)
    while _rank(n, level) > n:
        n += 1
    return n


@dataclass(frozen=True)
class ScoreBounds:
    """Per-bin conformal residuals (module doc). ``edges``: the inner bin edges over ``p``,
    increasing (bin ``i`` holds ``edges[i-1] <= p < edges[i]``); ``residuals``: per bin, the
    calibration residuals ``s - p`` sorted ascending (``len(edges) + 1`` bins); ``perfect``: the
    scorer is the simulator (``upper(p) = p``); ``provenance``: where the fit came from."""

    edges: tuple[float, ...] = ()
    residuals: tuple[tuple[float, ...], ...] = ((),)
    perfect: bool = False
    provenance: dict = field(default_factory=dict, compare=False)
    _arrays: tuple = field(default=(), init=False, repr=False, compare=False)

    def __post_init__(self):
        if len(self.residuals) != len(self.edges) + 1:
            raise ValueError(f"{len(self.residuals)} bins of residuals for {len(self.edges)} "
                             f"edges (expected {len(self.edges) + 1})")
        if any(b <= a for a, b in zip(self.edges, self.edges[1:])):
            raise ValueError("bin edges must increase")
        arrays = tuple(np.sort(np.asarray(r, dtype=np.float64)) for r in self.residuals)
        if any(a.size and not np.all(np.isfinite(a)) for a in arrays):
            raise ValueError("residuals must be finite")
        object.__setattr__(self, "_arrays", arrays)

    @classmethod
    def trivial(cls, note: str = "no calibration: every operation bounded by 1") -> ScoreBounds:
        """No calibration data: every upper bound is 1."""
        return cls(provenance={"source": "none", "note": note})

    @classmethod
    def zero_width(cls) -> ScoreBounds:
        """A perfect scorer (its predictions are the simulator's scores): ``upper(p) = p``."""
        return cls(perfect=True, provenance={"source": "perfect scorer"})

    @property
    def calibrated(self) -> bool:
        """Whether any bound can fall below 1 (a perfect scorer, or some residuals)."""
        return self.perfect or any(a.size for a in self._arrays)

    @property
    def counts(self) -> tuple[int, ...]:
        """The number of calibration residuals of each bin."""
        return tuple(int(a.size) for a in self._arrays)

    def bin_of(self, p: np.ndarray) -> np.ndarray:
        """The bin index of each score."""
        return np.searchsorted(np.asarray(self.edges, dtype=np.float64),
                               np.asarray(p, dtype=np.float64), side="right")

    def margins(self, level: float) -> np.ndarray:
        """Per bin, the conformal quantile ``q`` added to ``p`` at ``level`` (``inf`` where the
        bin has fewer than ``min_count(level)`` residuals; 0 for a perfect scorer)."""
        level = check_level(level)
        out = np.full(len(self._arrays), np.inf)
        for i, a in enumerate(self._arrays):
            k = _rank(a.size, level)
            if self.perfect:
                out[i] = 0.0
            elif k <= a.size:
                out[i] = a[k - 1]
        return out

    def upper(self, p, level: float) -> np.ndarray:
        """Upper bounds on the simulated scores of operations predicted ``p`` (float64, the
        shape of ``p``), each holding with probability at least ``level`` (module doc): ``p +
        q`` clipped to [0, 1]; 1 where the bin is too small for the level."""
        p = np.asarray(p, dtype=np.float64)
        q = self.margins(level)[self.bin_of(p)]
        with np.errstate(invalid="ignore"):
            return np.clip(np.where(np.isinf(q), 1.0, p + q), 0.0, 1.0)

    def rising(self, p, level: float) -> np.ndarray:
        """The least bound that rises with ``p`` and is at least ``upper`` everywhere at or below
        ``p``: ``max(upper(p), max over the bins below p's of min(1, their upper edge + q))``.
        ``upper`` is not monotone across bins (a bin of wide residuals below one of narrow
        ones); ``rising(p) >= upper(p')`` for every ``p' <= p``. O(m log bins)."""
        p = np.asarray(p, dtype=np.float64)
        q = self.margins(level)
        tops = np.where(np.isinf(q[:-1]), 1.0,
                        np.minimum(1.0, np.asarray(self.edges, dtype=np.float64) + q[:-1]))
        below = np.maximum.accumulate(np.concatenate(([0.0], tops)))  # best of bins under bin i
        return np.maximum(self.upper(p, level), below[self.bin_of(p)])

    def to_json(self) -> dict:
        """A JSON document (``from_json`` reads it back)."""
        return {"format": FORMAT, "version": 1, "perfect": self.perfect,
                "edges": [float(e) for e in self.edges],
                "residuals": [[float(x) for x in a] for a in self._arrays],
                "counts": list(self.counts), "provenance": dict(self.provenance)}

    @classmethod
    def from_json(cls, doc: dict) -> ScoreBounds:
        """The bounds of a ``to_json`` document; ``ValueError`` for another shape."""
        try:
            if doc.get("format") != FORMAT or doc.get("version") != 1:
                raise ValueError(f"not a {FORMAT} document, version 1")
            return cls(tuple(float(e) for e in doc["edges"]),
                       tuple(tuple(float(x) for x in r) for r in doc["residuals"]),
                       bool(doc.get("perfect", False)), dict(doc.get("provenance") or {}))
        except (AttributeError, KeyError, TypeError) as exc:
            raise ValueError(f"not a {FORMAT} document ({type(exc).__name__}: {exc})") from None


@dataclass(frozen=True)
class MeanBounds:
    """The bounds of a score that is the mean of two scorers' predictions (``p = (p_a + p_b) /
    2``, as the default scorer's guard gives on an unfamiliar assembly): ``upper(p, level) =
    max(first.rising(p, l2), second.rising(p, l2))`` with ``l2 = (1 + level) / 2``. The mean
    lies at or above the lower of the two predictions, so the bound is at least that scorer's
    bound at its own prediction and level ``l2``; whichever scorer that is, the bound fails only
    where one of the two scorers' bounds at ``l2`` fails, so with probability at most ``1 -
    level`` (the union bound; for operations exchangeable with both calibration sets). Both must
    be ``ScoreBounds``. ``perfect`` and ``calibrated`` when both are."""

    first: ScoreBounds
    second: ScoreBounds

    def upper(self, p, level: float) -> np.ndarray:
        half = (1.0 + check_level(level)) / 2.0
        return np.maximum(self.first.rising(p, half), self.second.rising(p, half))

    @property
    def perfect(self) -> bool:
        return self.first.perfect and self.second.perfect

    @property
    def calibrated(self) -> bool:
        return self.first.calibrated and self.second.calibrated

    @property
    def provenance(self) -> dict:
        def what(b: ScoreBounds) -> str:
            return ", ".join(str(b.provenance[k]) for k in ("model", "set", "date")
                             if k in b.provenance) or "uncalibrated"

        return {"model": f"the mean of two fits ({what(self.first)}; {what(self.second)})"}


def fit(predicted, simulated, *, bins: int = DEFAULT_BINS,
        provenance: dict | None = None) -> ScoreBounds:
    """Split-conformal bounds from a calibration set (module doc): ``predicted`` the model's
    expected scores, ``simulated`` the simulator's scores of the same operations (1-D, same
    length, in [0, 1]); ``bins`` bins at the quantiles of ``predicted`` (fewer where quantiles
    coincide). ``provenance`` is kept, with the counts added. ``ValueError`` for bad input."""
    p = np.asarray(predicted, dtype=np.float64)
    s = np.asarray(simulated, dtype=np.float64)
    if p.ndim != 1 or p.shape != s.shape:
        raise ValueError(f"predicted {p.shape} and simulated {s.shape}: two 1-D arrays, "
                         f"same length")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(s))):
        raise ValueError("scores must be finite")
    if p.size and (p.min() < 0 or p.max() > 1 or s.min() < 0 or s.max() > 1):
        raise ValueError("scores must lie in [0, 1]")
    if int(bins) < 1:
        raise ValueError(f"bins {bins!r}: at least 1")
    edges: tuple[float, ...] = ()
    if p.size:
        qs = np.quantile(p, np.arange(1, int(bins)) / int(bins))
        edges = tuple(float(e) for e in np.unique(qs) if p.min() < e)  # no empty first bin
    idx = np.searchsorted(np.asarray(edges), p, side="right")
    r = np.ceil((s - p) * _ROUND) / _ROUND  # rounded up: never narrower than fitted
    residuals = tuple(tuple(np.sort(r[idx == i]).tolist()) for i in range(len(edges) + 1))
    meta = dict(provenance or {})
    meta.update(operations=int(p.size), bins=len(edges) + 1)
    return ScoreBounds(edges, residuals, False, meta)


def save(bounds: ScoreBounds, path: str | Path = DEFAULT_PATH) -> Path:
    """Write ``bounds.to_json()`` to ``path`` atomically (a temporary file renamed), with the
    permissions of a committed file."""
    from rap.files import write_text_atomic

    return write_text_atomic(path, json.dumps(bounds.to_json(), separators=(",", ":")) + "\n")


def load(path: str | Path | None = None) -> ScoreBounds:
    """The bounds in ``path``; None: ``DEFAULT_PATH``, and where that file is absent,
    ``ScoreBounds.trivial()`` with a note saying so (every unsimulated operation bounded by 1).
    ``FileNotFoundError`` for a given path that is absent; ``ValueError`` for a bad document."""
    if path is None:
        if not DEFAULT_PATH.exists():
            return ScoreBounds.trivial(f"no calibration file {DEFAULT_PATH.name}: every "
                                       f"unsimulated operation bounded by 1")
        path = DEFAULT_PATH
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not JSON ({exc})") from None
    return ScoreBounds.from_json(doc)
