"""Checkpoints of the robustness CNN: weights plus everything needed to use them.

A checkpoint is a ``torch.save`` of one plain dict::

    format            "rap-farm/robustness-cnn"
    format_version    FORMAT_VERSION (int)
    config            ModelConfig.to_dict()
    state_dict        the network's tensors
    threshold         float: a score >= threshold is the class "high"
    data_fingerprint  hex SHA-256 of the training rows' sorted keys + the dataset metadata
    assemblies        [{"name", "geometry_hash", "rows", "high_fraction"}] trained on
    image_stats       summary statistics of the training images (see ``data.image_stats``)
    metrics           {"train": {...}, "holdout": {...} or absent}
    training          TrainConfig as a dict, class weights, dataset path, holdout, code version
    calibration       optional: {"temperature", "assemblies", "rows"} fitted on held-out rows

Every value is a tensor, str, int, float, bool, None, list or dict, so loading uses
``torch.load(weights_only=True)``: a file that holds any other object is refused and no code from
the file runs. Saving is atomic (temporary file + rename).
"""

from __future__ import annotations

import os
import pickle
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from rap.dataset import committed_file_mode
from rap.errors import InputError
from rap.model.network.cnn import ModelConfig, RobustnessCNN

__all__ = ["FORMAT", "FORMAT_VERSION", "Checkpoint", "save_checkpoint", "load_checkpoint"]

FORMAT = "rap-farm/robustness-cnn"
FORMAT_VERSION = 1
_PLAIN = (str, int, float, bool, type(None))


@dataclass(frozen=True)
class Checkpoint:
    """A loaded checkpoint: the rebuilt network (eval mode) and its metadata."""

    model: RobustnessCNN
    config: ModelConfig
    threshold: float
    data_fingerprint: str
    assemblies: list
    image_stats: dict
    metrics: dict
    training: dict
    path: str = ""
    calibration: dict | None = None


def _plain(value, where: str):
    """``value`` as plain containers only (numpy scalars become Python numbers, tuples lists), so
    that weights_only loading accepts it; anything else is a TypeError."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"checkpoint {where}: key {k!r} is not a str")
            out[k] = _plain(v, f"{where}.{k}")
        return out
    if isinstance(value, (list, tuple)):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.generic):
        value = value.item()
    if type(value) not in _PLAIN:
        raise TypeError(f"checkpoint {where}: {type(value).__name__} is not a plain value")
    return value


def save_checkpoint(path: str | Path, model: RobustnessCNN, *, threshold: float,
                    data_fingerprint: str, assemblies: list, image_stats: dict, metrics: dict,
                    training: dict, calibration: dict | None = None) -> Path:
    """Write ``model`` and its metadata to ``path`` atomically. Returns the path."""
    path = Path(path)
    meta = {"config": model.config.to_dict(), "threshold": float(threshold),
            "data_fingerprint": str(data_fingerprint), "assemblies": assemblies,
            "image_stats": image_stats, "metrics": metrics, "training": training}
    if calibration is not None:
        meta["calibration"] = calibration
    meta = _plain(meta, "metadata")
    blob = {"format": FORMAT, "format_version": FORMAT_VERSION, **meta,
            "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()}}
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".pt", dir=path.parent)
    os.fchmod(fd, committed_file_mode())  # mkstemp makes 0o600
    try:
        with os.fdopen(fd, "wb") as fh:
            torch.save(blob, fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_checkpoint(path: str | Path, device: str | torch.device = "cpu") -> Checkpoint:
    """Load a checkpoint written by ``save_checkpoint``; every failure is one ``InputError`` line."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such checkpoint file")
    if not zipfile.is_zipfile(path):
        raise InputError(f"{path}: not a readable checkpoint (corrupted or truncated: not a "
                         f"torch zip archive)")
    try:
        blob = torch.load(path, map_location=device, weights_only=True)
    except pickle.UnpicklingError as exc:
        lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
        if lines and "weights only" in lines[0].lower():
            why = next((ln for ln in lines if "Unsupported" in ln), lines[-1])
            raise InputError(f"{path}: refused: the checkpoint holds objects other than tensors "
                             f"and plain values, which are not loaded ({why[:200]})") from None
        first = lines[0] if lines else type(exc).__name__
        raise InputError(f"{path}: not a readable checkpoint ({first[:200]})") from None
    except Exception as exc:  # bytes from outside: whatever the reader trips over is bad input
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable checkpoint (corrupted or truncated: "
                         f"{first[:200]})") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise InputError(f"{path}: not a rap-farm robustness-CNN checkpoint")
    version = blob.get("format_version")
    if version != FORMAT_VERSION:
        raise InputError(f"{path}: checkpoint format version {version!r}; this rap-farm reads "
                         f"version {FORMAT_VERSION} (retrain with `rap-farm train`)")
    try:
        config = ModelConfig.from_dict(blob["config"])
        model = RobustnessCNN(config)
        model.load_state_dict(blob["state_dict"])
        ckpt = Checkpoint(model=model.to(device).eval(), config=config,
                          threshold=float(blob["threshold"]),
                          data_fingerprint=str(blob["data_fingerprint"]),
                          assemblies=list(blob["assemblies"]), image_stats=dict(blob["image_stats"]),
                          metrics=dict(blob["metrics"]), training=dict(blob["training"]),
                          path=str(path), calibration=blob.get("calibration"))
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: inconsistent checkpoint ({type(exc).__name__}: "
                         f"{first[:200]})") from None
    return ckpt
