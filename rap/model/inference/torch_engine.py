"""The planner's view of a trained robustness CNN: images in, P(high) and expected scores out.

    predictor = TorchPredictor.load("models/default.pt")          # device="cpu" by default
    p = predictor.prob_high(images)   # images: uint8 [N, 2, 64, 64] -> float64 [N]
    s = predictor.expected_score(images)   # the expected success rate (binomial head)
    predictor.threshold               # a score >= threshold is "high" (0.95 in the paper)
    predictor.is_high(images)         # p >= 0.5, the classifier's decision
    predictor.trained_on(geometry_hash), predictor.shift(images)   # distance from training data

``prob_high`` scores one batch in eval mode without gradients, through the checkpoint's head and
calibration temperature (``rap.model.network.heads``); the planner ranks the candidate operations of a
step by it. Loading never runs code from the file (see ``checkpoint``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from rap.errors import ParameterError
from rap.model.network import heads
from rap.model.network.checkpoint import Checkpoint, load_checkpoint
from rap.model.network.cnn import RobustnessCNN
from rap.model.data.rows import image_stats

__all__ = ["TorchPredictor", "batch_outputs", "resolve_device"]


def resolve_device(name: str | torch.device = "auto") -> torch.device:
    """``auto``: CUDA when present, else CPU; ``cpu``; ``cuda``. ``ParameterError`` (parameter
    ``device``) for CUDA when absent and for a name torch does not know."""
    name = str(name)
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise ParameterError("device", name, "no CUDA device is available", quote=False)
    try:
        return torch.device(name)
    except RuntimeError:
        raise ParameterError("device", name, "unknown device (auto, cpu or cuda)") from None


CPU_CHUNK = 64  # images per forward pass on the CPU: a bigger batch's activations overflow the
# caches (``python benchmarks/model.py``; docs/RESULTS.md)


@torch.inference_mode()
def batch_outputs(model: RobustnessCNN, images: np.ndarray, device: torch.device,
                  descriptors: np.ndarray | None = None) -> np.ndarray:
    """The network's raw outputs (logits) for uint8 images [N, 2, 64, 64] (and the operations'
    descriptors [N, k] when the network takes them): one forward pass, or on the CPU one per
    ``CPU_CHUNK`` images."""
    x = torch.from_numpy(np.ascontiguousarray(images)).to(device)
    d = None if descriptors is None else torch.from_numpy(
        np.ascontiguousarray(descriptors, dtype=np.float32)).to(device)
    if device.type != "cpu" or len(x) <= CPU_CHUNK:
        return model(x, d).double().cpu().numpy()
    return torch.cat([model(x[i:i + CPU_CHUNK], None if d is None else d[i:i + CPU_CHUNK])
                      for i in range(0, len(x), CPU_CHUNK)]).double().numpy()


def mirrored(images: np.ndarray) -> np.ndarray:
    """The left-right mirror of image pairs [N, C, H, W] (every channel): the mirrored operation,
    which the physics scores the same (the motion stays vertical; friction, contact and the
    perpendicular noise are symmetric)."""
    return np.ascontiguousarray(np.asarray(images)[..., ::-1])


class TorchPredictor:
    """A loaded checkpoint ready to score operations. With ``mirror``, the network's outputs are
    averaged over each pair and its mirror image (test-time augmentation: twice the inference)."""

    def __init__(self, checkpoint: Checkpoint, device: torch.device, mirror: bool = False):
        self.checkpoint = checkpoint
        self.device = device
        self.mirror = bool(mirror)
        self.model = checkpoint.model.to(device).eval()
        shape = (checkpoint.config.in_channels, checkpoint.config.image_size,
                 checkpoint.config.image_size)
        self.image_shape = shape

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", mirror: bool = False) -> "TorchPredictor":
        dev = resolve_device(device)
        return cls(load_checkpoint(path, device=dev), dev, mirror=mirror)

    @property
    def threshold(self) -> float:
        return self.checkpoint.threshold

    @property
    def head(self) -> str:
        return self.checkpoint.config.head

    @property
    def view(self) -> str:
        """The images the network takes (``rap.render.images.render_view``)."""
        return self.checkpoint.config.view

    @property
    def temperature(self) -> float:
        return float((self.checkpoint.calibration or {}).get("temperature", 1.0))

    @property
    def trials(self) -> int:
        return int(self.checkpoint.training.get("trials", 100))

    @property
    def config(self):
        return self.checkpoint.config

    @property
    def metrics(self) -> dict:
        return self.checkpoint.metrics

    @property
    def assemblies(self) -> list[dict]:
        return self.checkpoint.assemblies

    @property
    def data_fingerprint(self) -> str:
        return self.checkpoint.data_fingerprint

    @property
    def image_stats(self) -> dict:
        return self.checkpoint.image_stats

    @property
    def training(self) -> dict:
        return self.checkpoint.training

    @property
    def descriptors(self) -> tuple[str, ...]:
        """The geometric descriptors the network takes beside the images (``rap.model.data.descriptors``;
        empty: images only)."""
        return self.checkpoint.config.descriptors

    def prob_high(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        """P(high) for each image pair: uint8 [N, 2, 64, 64] -> float64 [N] (one batch)."""
        return heads.prob_high_np(self.outputs(images, descriptors), self.head, self.threshold,
                                  self.trials, self.temperature)

    def outputs(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        """Raw network outputs for uint8 images [N, 2, 64, 64] (checked), with the operations'
        descriptors float [N, k] when the network takes them (required then; the mirror image
        of an operation has the same descriptors)."""
        images = np.asarray(images)
        if images.dtype != np.uint8 or images.ndim != 4 or images.shape[1:] != self.image_shape:
            raise ValueError(f"images must be uint8 [N, {', '.join(map(str, self.image_shape))}], "
                             f"got {images.dtype} {list(images.shape)}")
        k = len(self.descriptors)
        if k:
            if descriptors is None or np.shape(descriptors) != (len(images), k):
                raise ValueError(f"this model takes descriptors float [N, {k}] beside the images "
                                 f"(rap.model.data.descriptors), got "
                                 f"{None if descriptors is None else list(np.shape(descriptors))}")
        else:
            descriptors = None
        if len(images) == 0:
            return np.zeros((0, 2 if self.head == "class" else 1), dtype=np.float64)
        self.model.eval()
        out = batch_outputs(self.model, images, self.device, descriptors)
        if self.mirror:
            out = (out + batch_outputs(self.model, mirrored(images), self.device, descriptors)) / 2
        return out

    def expected_score(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        """The expected success rate of each operation (binomial head; the class head can only
        give P(high), returned instead): float64 [N]."""
        return heads.expected_score_np(self.outputs(images, descriptors), self.head,
                                       self.temperature)

    def prob_high_and_expected(self, images: np.ndarray, descriptors: np.ndarray | None = None
                               ) -> tuple[np.ndarray, np.ndarray]:
        """``(prob_high, expected_score)`` from one forward pass (what RAP ranks by)."""
        out = self.outputs(images, descriptors)
        return (heads.prob_high_np(out, self.head, self.threshold, self.trials, self.temperature),
                heads.expected_score_np(out, self.head, self.temperature))

    def is_high(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        return self.prob_high(images, descriptors) >= 0.5

    def trained_on(self, geometry_hash: str) -> bool:
        """Whether an assembly with this geometry hash was in the training data."""
        for a in self.assemblies:
            h = a["geometry_hash"]
            if geometry_hash == h or (isinstance(h, list) and geometry_hash in h):
                return True
        return False

    def shift(self, images: np.ndarray) -> dict:
        """How far a batch of images lies from the training images: per channel, the z-score of
        the batch's mean foreground fraction against the training images' distribution, and the
        mean absolute difference of the coarse 8x8 foreground maps (0 same, 1 disjoint)."""
        ref = self.image_stats
        new = image_stats([np.asarray(images, dtype=np.uint8)])
        z = [(m - rm) / rs if rs > 0 else 0.0 for m, rm, rs in
             zip(new["foreground_mean"], ref["foreground_mean"], ref["foreground_std"])]
        coarse = float(np.abs(np.asarray(new["coarse_foreground"])
                              - np.asarray(ref["coarse_foreground"])).mean())
        return {"foreground_z": z, "coarse_difference": coarse, "rows": new["rows"]}
