"""A small network on the twelve geometric descriptors alone: the cascade's cheap scorer.

``DescriptorModel`` maps an operation's descriptors (``rap.model.data.descriptors.DESCRIPTORS``,
in that order; ``rap.model.data.batch_descriptors`` computes them in batches) to one logit of the
per-trial success probability, the binomial head of the CNN (``rap.model.network.heads``): the
expected score is its sigmoid and P(high) the binomial tail P(Bin(trials, p) >= k) at the
threshold, both through a calibration temperature fitted on held-out assemblies.

The file (``.npz``, read with ``allow_pickle=False``: nothing in it is executed) holds the input
standardisation (``mean``, ``scale``), the layers (``w0``, ``b0``, ``w1``, ...: float32, ReLU
between them, none after the last), and ``meta``: one JSON string with the threshold, trials,
temperature, the cascade's band, the SHA-256 of the CNN checkpoint it was fitted beside, and the
provenance (the command that made it, the training rows' fingerprint). ``save``/``load`` write and
read it (atomic write).

Cost: a few small matrix products, about 10 microseconds a call plus 1 microsecond an operation
on 2 cores for the shipped 12-128-128-64-1 network (26k parameters, 0.1 MB). numpy only.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from rap.model.inference.numpy_engine import _binomial_tail, _high_count

__all__ = ["DescriptorModel", "FORMAT"]

FORMAT = "rap-farm/descriptor-model"


class DescriptorModel:
    """An MLP over the descriptors with a binomial head (module doc). ``layers``: [(w [in, out],
    b [out])]; ``meta``: at least ``threshold``, ``trials``, ``temperature``."""

    def __init__(self, mean: np.ndarray, scale: np.ndarray, layers: list, meta: dict):
        self.mean = np.asarray(mean, np.float32)
        self.scale = np.asarray(scale, np.float32)
        self.layers = [(np.ascontiguousarray(w, np.float32), np.ascontiguousarray(b, np.float32))
                       for w, b in layers]
        self.meta = dict(meta)
        self.meta.setdefault("format", FORMAT)
        self.threshold = float(self.meta["threshold"])
        self.trials = int(self.meta["trials"])
        self.temperature = float(self.meta.get("temperature", 1.0))
        if self.mean.shape != (self.layers[0][0].shape[0],) or self.scale.shape != self.mean.shape:
            raise ValueError("standardisation and first layer disagree")

    def logits(self, descriptors: np.ndarray) -> np.ndarray:
        """The raw logit (before the temperature) of each row, float64 [N]."""
        x = (np.asarray(descriptors, np.float32) - self.mean) / self.scale
        last = len(self.layers) - 1
        for i, (w, b) in enumerate(self.layers):
            x = x @ w + b
            if i < last:
                np.maximum(x, 0.0, out=x)
        return x[:, 0].astype(np.float64)

    def prob_high_and_expected(self, descriptors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P(high), expected score), float64 [N] each."""
        p = 1.0 / (1.0 + np.exp(-self.logits(descriptors) / self.temperature))
        k = _high_count(self.threshold, self.trials)
        return _binomial_tail(p, self.trials, k), p

    def expected_score(self, descriptors: np.ndarray) -> np.ndarray:
        return 1.0 / (1.0 + np.exp(-self.logits(descriptors) / self.temperature))

    def prob_high(self, descriptors: np.ndarray) -> np.ndarray:
        return self.prob_high_and_expected(descriptors)[0]

    def save(self, path: str | Path) -> Path:
        """Write the model atomically (temporary file, renamed) as a committed file's mode."""
        from rap.files import committed_file_mode

        path = Path(path)
        arrays = {"mean": self.mean, "scale": self.scale,
                  "meta": np.array(json.dumps(self.meta, sort_keys=True))}
        for i, (w, b) in enumerate(self.layers):
            arrays[f"w{i}"], arrays[f"b{i}"] = w, b
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".npz")
        os.close(fd)
        try:
            np.savez(tmp, **arrays)
            os.chmod(tmp, committed_file_mode())
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        return path

    @classmethod
    def load(cls, path: str | Path) -> "DescriptorModel":
        """The model in ``path``; ``ValueError`` for a file of another format."""
        with np.load(path, allow_pickle=False) as z:
            try:
                meta = json.loads(str(z["meta"]))
                if meta.get("format") != FORMAT:
                    raise ValueError(f"{path}: not a {FORMAT} file")
                layers, i = [], 0
                while f"w{i}" in z.files:
                    layers.append((z[f"w{i}"], z[f"b{i}"]))
                    i += 1
                if not layers:
                    raise ValueError(f"{path}: no layers")
                return cls(z["mean"], z["scale"], layers, meta)
            except KeyError as exc:
                raise ValueError(f"{path}: missing {exc}") from None
