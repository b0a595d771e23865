"""Epoch states of a training run: saved after every epoch, so that an interrupted ``train``
continues where it stopped instead of starting over.

A state holds the weights, the optimiser's moments, both random generators (numpy's for shuffling
and augmentation, torch's for dropout) and the step counter; training resumed from it on the same
device gives bit-identical weights to an uninterrupted run. A state is keyed by everything that
decides the run (recipe, network, training rows' fingerprint, held-out assembly or family, initial
weights; not the device or thread count): one written by another training is not resumed.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from rap.errors import InputError

__all__ = ["EpochState", "capture", "load_state", "run_key", "save_state"]

FORMAT = 1
_NOT_IN_KEY = ("device", "num_threads")  # change speed or rounding, not the run


def run_key(config: dict, model_config: dict, fingerprint: str, holdout: str | None,
            holdout_family: str | None, init: dict | None) -> str:
    """Hex SHA-256 naming one training run (the state's key). O(size of the configs)."""
    cfg = {k: v for k, v in config.items() if k not in _NOT_IN_KEY}
    doc = {"config": cfg, "model_config": model_config, "rows": fingerprint, "holdout": holdout,
           "holdout_family": holdout_family, "init": init}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()


@dataclass
class EpochState:
    """Where a run stands after ``epoch`` completed epochs (``last``: the last epoch's running
    sums ``loss_sum``, ``hits``, ``seen`` for the final training metrics)."""

    key: str
    epoch: int
    global_step: int
    train_seconds: float
    model: dict
    optimizer: dict
    numpy_rng: dict
    torch_rng: torch.Tensor
    cuda_rng: list | None
    last: dict

    def restore(self, model: torch.nn.Module, opt: torch.optim.Optimizer,
                rng: np.random.Generator, device: torch.device) -> None:
        """Put the weights, the optimiser and both generators back as they were saved."""
        model.load_state_dict(self.model)
        opt.load_state_dict(self.optimizer)
        rng.bit_generator.state = self.numpy_rng
        torch.set_rng_state(self.torch_rng)
        if device.type == "cuda" and self.cuda_rng is not None:
            torch.cuda.set_rng_state_all(self.cuda_rng)


def capture(key: str, epoch: int, global_step: int, train_seconds: float, model: torch.nn.Module,
            opt: torch.optim.Optimizer, rng: np.random.Generator, device: torch.device,
            last: dict) -> EpochState:
    """The state of a run after ``epoch`` completed epochs."""
    return EpochState(key=key, epoch=epoch, global_step=global_step, train_seconds=train_seconds,
                      model=model.state_dict(), optimizer=opt.state_dict(),
                      numpy_rng=rng.bit_generator.state, torch_rng=torch.get_rng_state(),
                      cuda_rng=torch.cuda.get_rng_state_all() if device.type == "cuda" else None,
                      last=dict(last))


def save_state(path: str | Path, state: EpochState) -> None:
    """Write ``state`` to ``path`` atomically (a temporary file beside it, then a rename): an
    interruption leaves the previous epoch's state whole."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        torch.save({"format": FORMAT, **state.__dict__}, tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def load_state(path: str | Path, key: str) -> EpochState | None:
    """The state at ``path`` if it belongs to the run ``key``; None when there is none or it was
    written by another run. ``InputError`` for a file that is not an epoch state."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        doc = torch.load(path, map_location="cpu", weights_only=False)  # restore() moves it
    except Exception as e:  # noqa: BLE001 (any unreadable file is the same input error)
        raise InputError(f"{path}: not a training state ({type(e).__name__}); delete it to "
                         f"start afresh") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(f"{path}: not a training state of this version; delete it to start "
                         f"afresh")
    if doc.get("key") != key:
        return None
    doc.pop("format")
    return EpochState(**doc)
