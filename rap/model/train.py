"""Training the robustness CNN on a rap-farm dataset (optionally leaving one assembly out).

Adam with default parameters, cross-entropy over (not high, high). Class imbalance: the loss is
class-weighted with inverse class frequencies of the training rows (``w_c = N / (2 N_c)``,
``class_weighting="balanced"``; ``"none"`` for the plain loss); no resampling, so every row is seen
once an epoch. Reproducible on the CPU for a given seed (and thread count): the weights'
initialisation and dropout draw from a forked torch RNG seeded with ``seed`` and the shuffling from
``numpy.random.default_rng(seed)``; the caller's global RNG state is left as it was.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch
import torch.nn.functional as F

from rap import __version__
from rap.dataset import open_dataset
from rap.errors import InputError
from rap.model.checkpoint import save_checkpoint
from rap.model.cnn import ModelConfig, RobustnessCNN
from rap.model.data import (Selection, assembly_summary, data_fingerprint, image_stats, iter_rows,
                            labels_of, make_batches, select)
from rap.model.metrics import classification_metrics
from rap.model.predict import batch_prob_high, resolve_device

__all__ = ["TrainConfig", "TrainResult", "train", "predict_selection", "dataset_assemblies"]


@dataclass(frozen=True)
class TrainConfig:
    """How to train. ``num_threads`` 0 leaves torch's thread count alone."""

    epochs: int = 8
    batch_size: int = 64
    seed: int = 0
    device: str = "auto"
    threshold: float = 0.95
    class_weighting: str = "balanced"
    # "hflip" (off by default: in leave-one-assembly-out evaluation it did not help, 68.3% vs
    # 70.2% mean accuracy): mirror each training pair left-right with probability 1/2 (seeded). Exact for this
    # data: motion is normalised downward and the physics (no gravity, noise symmetric about the
    # path) is mirror-symmetric, so a mirrored operation is equally robust. "none": off.
    augment: str = "none"
    num_threads: int = 0
    max_memory_mb: float = 2048.0

    def __post_init__(self):
        if self.epochs < 1 or self.batch_size < 1:
            raise InputError("epochs and batch size must be at least 1")
        if self.class_weighting not in ("balanced", "none"):
            raise InputError(f"class weighting {self.class_weighting!r}: balanced or none")
        if self.augment not in ("hflip", "none"):
            raise InputError(f"augment {self.augment!r}: hflip or none")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class TrainResult:
    """A trained network and the metadata its checkpoint carries."""

    model: RobustnessCNN
    threshold: float
    data_fingerprint: str
    assemblies: list
    image_stats: dict
    metrics: dict
    training: dict

    def save(self, path: str | Path) -> Path:
        return save_checkpoint(path, self.model, threshold=self.threshold,
                               data_fingerprint=self.data_fingerprint, assemblies=self.assemblies,
                               image_stats=self.image_stats, metrics=self.metrics,
                               training=self.training)


def dataset_assemblies(root: str | Path) -> list[str]:
    """Sorted names of the assemblies present in a dataset."""
    col = open_dataset(root).to_table(columns=["assembly"]).column("assembly")
    return sorted(set(col.unique().to_pylist()))


def predict_selection(model: RobustnessCNN, sel: Selection, device: torch.device,
                      batch_size: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """(scores, P(high)) of every row of ``sel``, streamed in dataset order."""
    model.eval()
    scores, probs = [], []
    for images, s in iter_rows(sel, batch_size=batch_size):
        scores.append(s)
        probs.append(batch_prob_high(model, images, device))
    if not scores:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(scores), np.concatenate(probs)


class _Threads:
    """Set torch's intra-op thread count for a block (0: leave it)."""

    def __init__(self, n: int):
        self.n = n

    def __enter__(self):
        self.old = torch.get_num_threads()
        if self.n:
            torch.set_num_threads(self.n)

    def __exit__(self, *exc):
        torch.set_num_threads(self.old)


def train(root: str | Path, *, holdout: str | None = None, model_config: ModelConfig = ModelConfig(),
          config: TrainConfig = TrainConfig(),
          on_step: Callable[[dict], None] | None = None) -> TrainResult:
    """Train on every assembly of the dataset at ``root`` except ``holdout``; report metrics on it.

    ``on_step`` gets after every batch ``{"epoch", "epochs", "step", "steps", "loss", "accuracy"}``
    (running means over the epoch so far).
    """
    root = str(Path(root).resolve())
    names = dataset_assemblies(root)
    if holdout is not None and holdout not in names:
        raise InputError(f"--holdout {holdout}: no such assembly in {root} "
                         f"(has: {', '.join(names)})")
    sel = select(root, exclude=(holdout,) if holdout else ())
    device = resolve_device(config.device)
    t0 = time.perf_counter()
    with _Threads(config.num_threads), \
            torch.random.fork_rng(devices=[device.index or 0] if device.type == "cuda" else []):
        torch.manual_seed(config.seed)
        data = make_batches(sel, config.threshold, config.batch_size, config.max_memory_mb)
        counts = data.class_counts()
        if config.class_weighting == "balanced":
            weights = [len(data) / (2 * c) if c else 1.0 for c in counts]
        else:
            weights = [1.0, 1.0]
        model = RobustnessCNN(model_config).to(device)
        opt = torch.optim.Adam(model.parameters())
        w = torch.tensor(weights, dtype=torch.float32, device=device)
        rng = np.random.default_rng(config.seed)
        steps = -(-len(data) // config.batch_size)
        train_seconds = 0.0
        for epoch in range(config.epochs):
            model.train()
            loss_sum, hits, seen = 0.0, 0, 0
            te = time.perf_counter()
            for step, (images, labels) in enumerate(data.epoch(rng)):
                if config.augment == "hflip":
                    flip = rng.random(len(images)) < 0.5
                    images = np.where(flip[:, None, None, None], images[..., ::-1], images)
                x = torch.from_numpy(np.ascontiguousarray(images)).to(device)
                y = torch.from_numpy(labels).to(device)
                logits = model(x)
                loss = F.cross_entropy(logits, y, weight=w)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                loss_sum += loss.item() * len(y)
                hits += int((logits.argmax(1) == y).sum())
                seen += len(y)
                if on_step is not None:
                    on_step({"epoch": epoch + 1, "epochs": config.epochs, "step": step + 1,
                             "steps": steps, "loss": loss_sum / seen, "accuracy": hits / seen})
            train_seconds += time.perf_counter() - te
        model.eval()
        metrics = {"train": {"loss": loss_sum / seen, "accuracy": hits / seen,
                             "rows": len(data), "high_rows": int(counts[1]),
                             "samples_per_s": len(data) * config.epochs / max(train_seconds, 1e-9)}}
        if holdout is not None:
            scores, probs = predict_selection(model, select(root, include=(holdout,)), device)
            metrics["holdout"] = {"assembly": holdout,
                                  **classification_metrics(labels_of(scores, config.threshold), probs)}
    stats_source = getattr(data, "images", None)
    stats = image_stats((stats_source[i:i + 1024] for i in range(0, len(stats_source), 1024))
                        if stats_source is not None else (im for im, _ in iter_rows(sel)))
    training = {"config": config.to_dict(), "dataset": root, "holdout": holdout,
                "class_counts": [int(c) for c in counts], "class_weights": weights,
                "device": str(device), "seconds": time.perf_counter() - t0,
                "code_version": __version__, "torch_version": str(torch.__version__)}
    return TrainResult(model=model.cpu(), threshold=float(config.threshold),
                       data_fingerprint=data_fingerprint(sel),
                       assemblies=assembly_summary(sel, config.threshold), image_stats=stats,
                       metrics=metrics, training=training)
