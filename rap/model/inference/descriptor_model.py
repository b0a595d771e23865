"""A model of the twelve geometric descriptors alone: the cascade's cheap scorer.

``DescriptorModel`` maps an operation's descriptors (``rap.model.data.descriptors.DESCRIPTORS``,
in that order; ``rap.model.data.batch_descriptors`` computes them in batches) to one logit of the
per-trial success probability, by gradient-boosted trees (``meta["kind"] == "gbt"``: a LightGBM
booster trained with the cross-entropy objective on the success rates, its raw score the logit;
the shipped kind) or by a small MLP (``"mlp"``), the binomial head of the CNN (``rap.model.network.heads``): the
expected score is its sigmoid and P(high) the binomial tail P(Bin(trials, p) >= k) at the
threshold, both through a calibration temperature fitted on held-out assemblies.

Inputs: the descriptors, then ``log(LOG_EPS + x)`` of the columns ``meta["log_columns"]`` (the
range's width and margin and the contact and depth numbers: what matters there is a small
angle's or length's order of magnitude, which a standardised input hides), standardised.

The file (``.npz``, read with ``allow_pickle=False``: nothing in it is executed) holds, for an
MLP, the input standardisation (``mean``, ``scale``) and the layers (``w0``, ``b0``, ``w1``, ...:
float32, ReLU between them, none after the last); for trees, ``booster``: LightGBM's text
model (parsed by LightGBM, no code); and ``meta``: one JSON string with the threshold, trials,
temperature, the cascade's band, the SHA-256 of the CNN checkpoint it was fitted beside, and the
provenance (the command that made it, the training rows' fingerprint). ``save``/``load`` write and
read it (atomic write).

Cost: trees: one ``Booster.predict`` call on one thread, about 0.1 ms for 4 operations with the
shipped 400 trees of 63 leaves (2.8 MB of text, 0.8 MB compressed); loading 0.1-0.3 s. An MLP:
a few small matrix products, about 10 microseconds a call. numpy, and lightgbm for trees.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Sequence

import numpy as np

from rap.stats import binomial_tail, high_count

__all__ = ["DescriptorModel", "Familiarity", "FORMAT", "LOG_EPS", "SIZE_COLUMNS", "features",
           "size_free"]

FORMAT = "rap-farm/descriptor-model"
LOG_EPS = 1e-4
#: the descriptors that measure an assembly's size rather than its shape kind: ``moving_parts``,
#: ``fixed_parts`` and ``log_area_fraction`` of ``rap.model.data.descriptors.DESCRIPTORS``
SIZE_COLUMNS = (4, 5, 6)


def size_free(log_columns=()) -> list[int]:
    """The columns of ``features(descriptors, log_columns)`` that do not count parts: the twelve
    descriptors but ``SIZE_COLUMNS``, then the logarithms of ``log_columns`` but theirs."""
    logs = [12 + i for i, c in enumerate(log_columns) if c not in SIZE_COLUMNS]
    return [c for c in range(12) if c not in SIZE_COLUMNS] + logs


def features(descriptors: np.ndarray, log_columns=()) -> np.ndarray:
    """The network's inputs before standardisation: the descriptors, then ``log(LOG_EPS + x)``
    of ``log_columns``; float32 [N, k + len(log_columns)]."""
    x = np.asarray(descriptors, np.float32)
    if not len(log_columns):
        return x
    logs = np.log(np.float32(LOG_EPS) + np.maximum(x[:, list(log_columns)], 0.0))
    return np.concatenate([x, logs], axis=1)


class DescriptorModel:
    """Trees or an MLP over the descriptors with a binomial head (module doc). ``layers``: [(w
    [in, out], b [out])] (an MLP) or ``booster``: a LightGBM model's text (trees); ``meta``: at
    least ``threshold``, ``trials``, ``temperature``."""

    def __init__(self, mean: np.ndarray, scale: np.ndarray, layers: list, meta: dict,
                 booster: str | None = None):
        self.booster_text = booster
        self._booster = None
        if booster is not None:
            import lightgbm

            self._booster = lightgbm.Booster(model_str=booster)
            meta = {**meta, "kind": "gbt"}
            k = self._booster.num_feature()
            mean, scale = np.zeros(k), np.ones(k)
            layers = [(np.zeros((k, 1)), np.zeros(1))]
        self.mean = np.asarray(mean, np.float32)
        self.scale = np.asarray(scale, np.float32)
        self.layers = [(np.ascontiguousarray(w, np.float32), np.ascontiguousarray(b, np.float32))
                       for w, b in layers]
        self.meta = dict(meta)
        self.meta.setdefault("format", FORMAT)
        self.threshold = float(self.meta["threshold"])
        self.trials = int(self.meta["trials"])
        self.temperature = float(self.meta.get("temperature", 1.0))
        self.log_columns = tuple(int(c) for c in self.meta.get("log_columns", ()))
        if self.mean.shape != (self.layers[0][0].shape[0],) or self.scale.shape != self.mean.shape:
            raise ValueError("standardisation and first layer disagree")

    def logits(self, descriptors: np.ndarray) -> np.ndarray:
        """The raw logit (before the temperature) of each row, float64 [N]."""
        if self._booster is not None:
            x = np.asarray(descriptors, np.float64)
            if not len(x):
                return np.zeros(0)
            return np.asarray(self._booster.predict(x, raw_score=True, validate_features=False,
                                                    num_threads=1), np.float64)
        x = (features(descriptors, self.log_columns) - self.mean) / self.scale
        last = len(self.layers) - 1
        for i, (w, b) in enumerate(self.layers):
            x = x @ w + b
            if i < last:
                np.maximum(x, 0.0, out=x)
        return x[:, 0].astype(np.float64)

    def prob_high_and_expected(self, descriptors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P(high), expected score), float64 [N] each."""
        p = 1.0 / (1.0 + np.exp(-self.logits(descriptors) / self.temperature))
        k = high_count(self.threshold, self.trials)
        return binomial_tail(p, self.trials, k), p

    def expected_score(self, descriptors: np.ndarray) -> np.ndarray:
        return 1.0 / (1.0 + np.exp(-self.logits(descriptors) / self.temperature))

    def prob_high(self, descriptors: np.ndarray) -> np.ndarray:
        return self.prob_high_and_expected(descriptors)[0]

    def save(self, path: str | Path) -> Path:
        """Write the model atomically (temporary file, renamed) as a committed file's mode."""
        from rap.files import write_bytes_atomic

        path = Path(path)
        arrays = {"mean": self.mean, "scale": self.scale,
                  "meta": np.array(json.dumps(self.meta, sort_keys=True))}
        if self.booster_text is not None:
            arrays["booster"] = np.array(self.booster_text)
        else:
            for i, (w, b) in enumerate(self.layers):
                arrays[f"w{i}"], arrays[f"b{i}"] = w, b
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        return write_bytes_atomic(path, buf.getvalue())

    @staticmethod
    def read_meta(path: str | Path) -> dict:
        """The ``meta`` of the model in ``path``, without reading its trees or layers (what a
        caller checks before it loads); ``ValueError`` for a file of another format."""
        with np.load(path, allow_pickle=False) as z:
            return _meta(z, path)

    @classmethod
    def load(cls, path: str | Path) -> "DescriptorModel":
        """The model in ``path``; ``ValueError`` for a file of another format."""
        with np.load(path, allow_pickle=False) as z:
            meta = _meta(z, path)
            try:
                if "booster" in z.files:
                    return cls(z["mean"], z["scale"], [], meta, booster=str(z["booster"]))
                layers, i = [], 0
                while f"w{i}" in z.files:
                    layers.append((z[f"w{i}"], z[f"b{i}"]))
                    i += 1
                if not layers:
                    raise ValueError(f"{path}: no layers")
                return cls(z["mean"], z["scale"], layers, meta)
            except KeyError as exc:
                raise ValueError(f"{path}: missing {exc}") from None


def _meta(z, path: str | Path) -> dict:
    """``meta`` of an open model file ``z`` (``np.load``), checked to be of this format."""
    try:
        meta = json.loads(str(z["meta"]))
    except KeyError as exc:
        raise ValueError(f"{path}: missing {exc}") from None
    if meta.get("format") != FORMAT:
        raise ValueError(f"{path}: not a {FORMAT} file")
    return meta



class Familiarity:
    """How far an operation's descriptors lie from the descriptor model's training rows: the mean
    distance to the ``k`` nearest of a seeded ``reference`` sample of the training rows, in the
    standardised features ``features(descriptors, log_columns)`` restricted to ``columns`` and
    clipped to the training rows' range ``[low, high]``; ``limit`` is the ``quantile`` of that
    distance over training rows outside the reference. ``outside(descriptors)`` is the share of
    rows beyond the limit, what the cascade's guard compares with ``share``
    (``rap.model.inference.cascade``). Chosen by measurement over a global Mahalanobis distance
    and the trees' disagreement with the CNN, which did not separate new shape kinds from fresh
    seeds of the training families (research/README.md, "Leave one family out").

    Size is not a shape kind: the part counts and the area fraction are left out of ``columns``
    (``size_free``), and a feature beyond the training range counts as its edge (the trees
    answer there as at the edge). With every feature, unclipped, every assembly of 12 parts or
    more was unfamiliar (a 5 x 5 grid: all 64 sampled operations beyond the limit) and its whole
    graph went to the CNN (research/README.md, "The guard without size").

    Kept beside the model as ``NAME.guard.npz`` (``allow_pickle=False``): ``mean``, ``scale``,
    ``reference`` (float16: standardised numbers, a thousandth apart; the used columns), and
    ``meta`` (JSON: k, limit, share, quantile, log columns, columns, low, high, counts). A file
    without ``columns`` uses every feature, unclipped.
    Cost: a brute-force [N, R] distance matrix, tens of milliseconds for 64 operations against
    the shipped 60,000 reference rows (once an assembly); the file is about 2 MB. numpy only."""

    def __init__(self, mean, scale, reference, meta: dict):
        self.mean = np.asarray(mean, np.float64)
        self.scale = np.asarray(scale, np.float64)
        self.reference = np.ascontiguousarray(reference, np.float32)
        self.meta = dict(meta)
        self.k = int(self.meta["k"])
        self.limit = float(self.meta["limit"])
        self.share = float(self.meta["share"])
        self.log_columns = tuple(int(c) for c in self.meta.get("log_columns", ()))
        cols = self.meta.get("columns")
        self.columns = None if cols is None else [int(c) for c in cols]
        self.low = None if cols is None else np.asarray(self.meta["low"], np.float64)
        self.high = None if cols is None else np.asarray(self.meta["high"], np.float64)
        self._ref_sq = (self.reference.astype(np.float64) ** 2).sum(axis=1)

    @classmethod
    def fit(cls, descriptors: np.ndarray, log_columns=(), *, reference: int = 60000, k: int = 5,
            quantile: float = 0.9, share: float = 0.6, probe: int = 5000,
            columns: Sequence[int] | None = None,
            rng: np.random.Generator) -> "Familiarity":
        """Fitted on training rows' descriptors: a seeded reference sample, the limit measured
        on ``probe`` other rows. ``columns``: the features used (default ``size_free``)."""
        f = features(descriptors, log_columns).astype(np.float64)
        cols = list(size_free(log_columns) if columns is None else columns)
        f = f[:, cols]
        low, high = f.min(axis=0), f.max(axis=0)
        mean, scale = f.mean(axis=0), f.std(axis=0) + 1e-9
        order = rng.permutation(len(f))
        ref, others = order[:reference], order[reference:reference + probe]
        out = cls(mean, scale, (f[ref] - mean) / scale,
                  {"k": k, "limit": 0.0, "share": share, "quantile": quantile,
                   "log_columns": list(log_columns), "columns": cols,
                   "low": low.tolist(), "high": high.tolist(), "rows": int(len(f)),
                   "reference": int(len(ref)), "probe": int(len(others))})
        out.limit = float(np.quantile(out.distance(descriptors[others]), quantile))
        out.meta["limit"] = out.limit
        return out

    def distance(self, descriptors: np.ndarray) -> np.ndarray:
        """Mean distance of each row to its ``k`` nearest reference rows, float64 [N]."""
        f = features(descriptors, self.log_columns).astype(np.float64)
        if self.columns is not None:
            f = np.clip(f[:, self.columns], self.low, self.high)
        z = (f - self.mean) / self.scale
        d2 = (z ** 2).sum(axis=1)[:, None] + self._ref_sq[None, :] - 2.0 * z @ self.reference.T
        near = np.partition(np.maximum(d2, 0.0), self.k - 1, axis=1)[:, :self.k]
        return np.sqrt(near).mean(axis=1)

    def outside(self, descriptors: np.ndarray) -> float:
        """The share of rows farther than ``limit`` (0 for no rows)."""
        if not len(descriptors):
            return 0.0
        return float(np.mean(self.distance(descriptors) > self.limit))

    def save(self, path: str | Path) -> Path:
        from rap.files import write_bytes_atomic

        buf = io.BytesIO()
        np.savez_compressed(buf, mean=self.mean, scale=self.scale,
                            reference=self.reference.astype(np.float16),  # 2 bytes a number
                            meta=np.array(json.dumps({**self.meta, "format": FORMAT + "/guard"},
                                                     sort_keys=True)))
        return write_bytes_atomic(Path(path), buf.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> "Familiarity":
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("format") != FORMAT + "/guard":
                raise ValueError(f"{path}: not a descriptor guard file")
            return cls(z["mean"], z["scale"], z["reference"], meta)
