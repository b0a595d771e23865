"""The robustness CNN (paper, section 7): the network and its configuration, nothing else.

Input: a batch of 2-channel 64x64 images (channel 0 the start image, channel 1 the goal image of an
assembly operation), float in [0, 1] — ``RobustnessCNN.forward`` takes uint8 or float and scales
uint8 itself, so callers can keep images as uint8 until the batch is on the device. Output: the
head's logits (``rap.model.network.heads``): with ``head="class"`` (the paper's) the two classes, index 0
"not high" and index 1 "high" (score >= the threshold stored in the checkpoint, 0.95 in the
paper); with ``head="binomial"`` one logit of the per-trial success probability. A network configured with
``descriptors`` (names from ``rap.model.data.descriptors.DESCRIPTORS``) also takes those geometric
numbers of each operation, float [N, k]: batch-normalised and appended to the flattened
convolution features, before the fully connected layers.

Four convolutions with 4x4 kernels, each followed by ReLU and 2x2 max-pooling (``norm="batch"``:
batch normalisation after each convolution; a convolution computes only the rows and columns that
the pooling reads, except while batch statistics are gathered); three fully connected layers with
ReLU and dropout; a final linear layer to the head's outputs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
import torch.nn as nn
import torch.nn.functional as F

from rap.config import strict_from_dict
from rap.model.network.heads import HEADS, out_features

__all__ = ["ModelConfig", "RobustnessCNN", "NOT_HIGH", "HIGH"]

NOT_HIGH = 0
HIGH = 1


@dataclass(frozen=True)
class ModelConfig:
    """Shape of the network. ``channels`` are the four convolutions' output channels, ``hidden``
    the three fully connected layers' widths; ``norm`` "none" (the paper) or "batch"; ``head``
    "class" (the paper, ``n_classes`` outputs) or "binomial" (one output); ``view`` the input
    images: "pair" (start, goal) or "pair+crop" (and the close-up of the mating region)."""

    in_channels: int = 2
    image_size: int = 64
    channels: tuple[int, int, int, int] = (16, 32, 64, 64)
    kernel_size: int = 4
    padding: int = 2
    hidden: tuple[int, int, int] = (256, 128, 64)
    dropout: float = 0.3
    n_classes: int = 2
    norm: str = "none"
    head: str = "class"
    view: str = "pair"  # input images (rap.render.images.VIEWS): in_channels must match
    descriptors: tuple[str, ...] = ()  # geometric descriptors beside the images (none: images only)

    def __post_init__(self):
        from rap.render.images import view_channels

        if view_channels(self.view) != self.in_channels:
            raise ValueError(f"ModelConfig: view {self.view!r} has {view_channels(self.view)} "
                             f"channels, in_channels is {self.in_channels}")
        if self.norm not in ("none", "batch"):
            raise ValueError(f"ModelConfig: norm must be none or batch, not {self.norm!r}")
        if self.head not in HEADS:
            raise ValueError(f"ModelConfig: head must be one of {HEADS}, not {self.head!r}")
        # from_dict hands lists over; keep the dataclass hashable and comparable
        object.__setattr__(self, "channels", tuple(int(c) for c in self.channels))
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))
        object.__setattr__(self, "descriptors", tuple(str(d) for d in self.descriptors))
        from rap.model.data.descriptors import DESCRIPTORS

        unknown = [d for d in self.descriptors if d not in DESCRIPTORS]
        if unknown or len(set(self.descriptors)) != len(self.descriptors):
            raise ValueError(f"ModelConfig: descriptors must be distinct names of "
                             f"{', '.join(DESCRIPTORS)} (got {', '.join(self.descriptors)})")
        if len(self.channels) != 4 or len(self.hidden) != 3:
            raise ValueError("ModelConfig: four convolution and three hidden layers")
        if self.feature_size() < 1:
            raise ValueError("ModelConfig: image too small for four conv+pool stages")

    def feature_size(self) -> int:
        """Side of the feature map after the four conv + pool stages."""
        s = self.image_size
        for _ in self.channels:
            s = (s + 2 * self.padding - self.kernel_size + 1) // 2
        return s

    def to_dict(self) -> dict:
        """Plain JSON-able dict (lists, ints, floats) as stored in a checkpoint."""
        d = asdict(self)
        d["channels"] = list(self.channels)
        d["hidden"] = list(self.hidden)
        if self.descriptors:  # absent when none: checkpoints of images-only networks as before
            d["descriptors"] = list(self.descriptors)
        else:
            del d["descriptors"]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "ModelConfig":
        return strict_from_dict(cls, d, "model config fields")


class RobustnessCNN(nn.Module):
    """start/goal image pair -> the head's logits (see the module docstring)."""

    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        layers: list[nn.Module] = []
        c_in = config.in_channels
        for c_out in config.channels:
            layers.append(nn.Conv2d(c_in, c_out, config.kernel_size, padding=config.padding,
                                    bias=config.norm == "none"))
            if config.norm == "batch":
                layers.append(nn.BatchNorm2d(c_out))
            layers += [nn.ReLU(inplace=True), nn.MaxPool2d(2)]
            c_in = c_out
        self.features = nn.Sequential(*layers)
        width = c_in * config.feature_size() ** 2
        if config.descriptors:
            self.descriptor_norm = nn.BatchNorm1d(len(config.descriptors))
            width += len(config.descriptors)
        head: list[nn.Module] = [nn.Flatten()]
        for h in config.hidden:
            head += [nn.Linear(width, h), nn.ReLU(inplace=True), nn.Dropout(config.dropout)]
            width = h
        head.append(nn.Linear(width, config.n_classes if config.head == "class"
                              else out_features(config.head)))
        self.head = nn.Sequential(*head)
        # channels-last convolutions and pooling: faster on CPU (oneDNN; docs/RESULTS.md), same results
        self.to(memory_format=torch.channels_last)

    def forward(self, x: torch.Tensor, descriptors: torch.Tensor | None = None) -> torch.Tensor:
        """Logits of images x [N, C, 64, 64] (and, when configured, descriptors [N, k])."""
        if x.dtype == torch.uint8:
            x = x.float().div_(255.0)
        h = x.contiguous(memory_format=torch.channels_last)
        # batch statistics in training would see the dropped rows: there, the whole outputs
        even = not (self.training and self.config.norm == "batch")
        for layer in self.features:
            h = _even_conv(layer, h) if even and isinstance(layer, nn.Conv2d) else layer(h)
        if self.config.descriptors:
            if descriptors is None:
                raise ValueError("this network takes geometric descriptors beside the images")
            h = torch.cat([h.flatten(1), self.descriptor_norm(descriptors.float())], dim=1)
        return self.head(h)  # head[0] flattens (a no-op on the concatenated features)

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())


def _even_conv(conv: nn.Conv2d, x: torch.Tensor) -> torch.Tensor:
    """``conv(x)`` without the last row (column) of an odd-sized output, which the floor 2x2
    max-pooling after it never reads: the same values where kept (one less row of padding at
    the bottom and right). With 4x4 kernels and padding 2 the stages' 65, 33, 17 and 9 become
    64, 32, 16 and 8: 11% fewer multiply-adds, the same network (and the same gradients)."""
    p, k = conv.padding, conv.kernel_size
    if isinstance(p, str) or conv.stride != (1, 1) or conv.dilation != (1, 1):
        return conv(x)
    dh = (x.shape[-2] + 2 * p[0] - k[0] + 1) % 2
    dw = (x.shape[-1] + 2 * p[1] - k[1] + 1) % 2
    if not (dh or dw):
        return conv(x)
    return F.conv2d(F.pad(x, (p[1], p[1] - dw, p[0], p[0] - dh)), conv.weight, conv.bias)
