"""Torch-free inference of the robustness CNN, so that a one-off ``rap-farm plan`` starts quickly.

Importing torch takes 2-4 s on a 2-core machine, more than planning a 7-part assembly; loading a
checkpoint through ``rap.model`` adds pyarrow and pandas. This module reads the same checkpoint file
(``rap.model.network.checkpoint``: a ``torch.save`` zip archive of plain values and tensors) with the
standard library and numpy, and runs the forward pass of ``rap.model.network.cnn.RobustnessCNN`` in numpy:
four (4x4 convolution, batch normalisation when ``norm="batch"``, ReLU, 2x2 max-pooling) stages,
three (linear, ReLU) layers (dropout is the identity at inference; a network with geometric
descriptors takes them batch-normalised beside the flattened features), a final linear layer, and the
head of ``rap.model.network.heads`` with the checkpoint's calibration temperature: the softmax probability
of "high" (``head="class"``) or the binomial tail P(Bin(n, p) >= k) (``head="binomial"``).

Contract:

* ``load_numpy_predictor(path)`` returns a ``NumpyPredictor`` (``prob_high``, ``expected_score``,
  ``outputs``, ``threshold``, ``assemblies``, ``image_stats``, ``data_fingerprint``, like
  ``rap.model.inference.torch_engine.TorchPredictor``), or ``None`` when the file is not exactly one of the
  architectures above (other config fields or values, other layer names or shapes, other pickled
  objects): the caller then loads it with torch. Nothing in the file
  is executed; the unpickler admits three globals (``OrderedDict``, torch's tensor rebuild
  function and storage types), which it maps to numpy.
* Results equal torch's to float32 rounding (about 1e-6 in P(high));
  ``tests/model/inference/test_numpy_engine.py`` compares both on the shipped model and on a freshly built network,
  so a change of ``RobustnessCNN`` that this module does not follow fails there.

Cost: about 23 M multiply-adds per image pair (the convolutions skip the output rows and columns
that the floor pooling drops, as ``RobustnessCNN`` does at inference): per stage one im2col copy
(``kh`` strided copies of overlapping kernel rows) and one BLAS matmul, batch norm folded into the
weights, pooling before bias and ReLU. 0.5-0.6 ms per operation on 2 cores at batches of 4-16
(torch, once imported: 0.2-0.27 ms; ``python -m research.benchmarks.even_conv``), batches of
``CHUNK`` images at a time to bound memory. No torch, no ray, no pyarrow.
"""

from __future__ import annotations

import math
import pickle
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

__all__ = ["NumpyPredictor", "load_numpy_predictor", "read_torch_checkpoint", "CHUNK",
           "binomial_tail", "high_count"]

CHUNK = 64  # images per forward pass (memory: ~40 MB of im2col buffers at 64)

_FORMAT = "rap-farm/robustness-cnn"
_FORMAT_VERSION = 1
_CONFIG_KEYS = {"in_channels", "image_size", "channels", "kernel_size", "padding", "hidden",
                "dropout", "n_classes"}
_OPTIONAL_KEYS = {"norm", "head", "view", "descriptors"}  # absent in older checkpoints:
# "none", "class", "pair", () (images only)
_DESCRIPTOR_NORM = "descriptor_norm"  # BatchNorm1d of the geometric descriptors, when configured
_LINEAR = ("head.1", "head.4", "head.7", "head.10")
_STORAGES = {"FloatStorage": np.float32, "DoubleStorage": np.float64, "HalfStorage": np.float16,
             "LongStorage": np.int64, "IntStorage": np.int32, "ShortStorage": np.int16,
             "CharStorage": np.int8, "ByteStorage": np.uint8, "BoolStorage": np.bool_}


class _Storage:
    """Stands for a torch storage type (``torch.FloatStorage``...) in the unpickled data."""

    def __init__(self, name: str):
        self.dtype = np.dtype(_STORAGES[name])


def _rebuild_tensor(storage, offset, size, stride, *_ignored):
    item = storage.dtype.itemsize
    if not size:
        return storage[offset:offset + 1].reshape(()).copy()
    return np.lib.stride_tricks.as_strided(storage[offset:], shape=tuple(size),
                                           strides=tuple(s * item for s in stride)).copy()


class _Unpickler(pickle.Unpickler):
    """Admits OrderedDict, torch's tensor rebuild function and storage types; nothing else."""

    def __init__(self, fh, archive: zipfile.ZipFile, prefix: str):
        super().__init__(fh)
        self._archive, self._prefix = archive, prefix

    def find_class(self, module, name):
        if (module, name) == ("collections", "OrderedDict"):
            return OrderedDict
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor
        if module == "torch" and name in _STORAGES:
            return _Storage(name)
        raise pickle.UnpicklingError(f"{module}.{name} is not admitted")

    def persistent_load(self, pid):
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"
                and isinstance(pid[1], _Storage)):
            raise pickle.UnpicklingError("unexpected persistent id")
        _, storage, key, _location, numel = pid
        raw = self._archive.read(f"{self._prefix}/data/{key}")
        return np.frombuffer(raw, dtype=storage.dtype, count=int(numel))


def read_torch_checkpoint(path: str | Path) -> dict:
    """The checkpoint's top-level object with tensors as numpy arrays. Raises ``ValueError`` or
    ``pickle.UnpicklingError`` for anything but plain values and tensors."""
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
        pkl = [n for n in names if n.endswith("/data.pkl")]
        if len(pkl) != 1:
            raise ValueError("not a torch zip checkpoint")
        prefix = pkl[0][: -len("/data.pkl")]
        if f"{prefix}/byteorder" in names and zf.read(f"{prefix}/byteorder").strip() != b"little":
            raise ValueError("big-endian checkpoint")
        with zf.open(pkl[0]) as fh:
            return _Unpickler(fh, zf, prefix).load()


def _pool_relu(y: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MaxPool2d(2) (floor), then + bias and ReLU, on NHWC float32: equal to bias, ReLU, then
    pooling (adding a constant and ReLU are monotone, so they commute with the maximum exactly),
    on a quarter of the values. The maximum of the four strided quarter views."""
    h2, w2 = y.shape[1] // 2, y.shape[2] // 2
    out = np.maximum(y[:, 0:2 * h2:2, 0:2 * w2:2], y[:, 0:2 * h2:2, 1:2 * w2:2])
    np.maximum(out, y[:, 1:2 * h2:2, 0:2 * w2:2], out=out)
    np.maximum(out, y[:, 1:2 * h2:2, 1:2 * w2:2], out=out)
    out += b
    return np.maximum(out, 0.0, out=out)


def _conv_nhwc(x: np.ndarray, w: np.ndarray, pad: int, even: bool = False) -> np.ndarray:
    """Conv2d (stride 1, zero padding) of NHWC input by im2col: NHWC output.

    In NHWC the ``kw * C`` values under one kernel row are contiguous in the padded input, so the
    columns (kh, kw, C) are filled by ``kh`` copies of an overlapping strided view (each row of the
    view one kernel row's window), a third of the element-wise copies of a (kh x kw) slice loop;
    the product is one BLAS matmul. ``even``: compute only the first even number of output rows
    and columns, all that a following floor 2x2 max-pooling reads (the same values; with the
    shipped network's 4x4 kernels and padding 2 the stages' 65, 33, 17 and 9 become 64, 32, 16
    and 8: 11% fewer multiply-adds). Memory: ``N * Ho * Wo * kh * kw * C`` float32."""
    n, h, wd, c = x.shape
    o, _, kh, kw = w.shape
    xp = np.pad(x, ((0, 0), (pad, pad), (pad, pad), (0, 0)))
    ho, wo = h + 2 * pad - kh + 1, wd + 2 * pad - kw + 1
    if even:
        ho, wo = ho - ho % 2, wo - wo % 2
    s = xp.strides
    rows = np.lib.stride_tricks.as_strided(xp, (n, xp.shape[1], wo, kw * c),
                                           (s[0], s[1], s[2], s[3]), writeable=False)
    cols = np.empty((n, ho, wo, kh, kw * c), np.float32)
    for i in range(kh):
        cols[:, :, :, i, :] = rows[:, i:i + ho]
    wm = w.transpose(0, 2, 3, 1).reshape(o, kh * kw * c)
    return (cols.reshape(n * ho * wo, kh * kw * c) @ wm.T).reshape(n, ho, wo, o)


class NumpyPredictor:
    """P(high) of image pairs with a checkpoint's weights, in numpy (see module doc)."""

    engine = "numpy"

    def __init__(self, blob: dict, path: str = "", mirror: bool = False):
        self.mirror = bool(mirror)  # average the outputs over each pair and its mirror image
        cfg = blob["config"]
        self.config = dict(cfg)
        self.path = path
        self.padding = int(cfg["padding"])
        self.norm = cfg.get("norm", "none")
        self.head = cfg.get("head", "class")
        self.view = cfg.get("view", "pair")  # which images to render (rap.render.images.VIEWS)
        self.descriptors = tuple(cfg.get("descriptors", ()))  # rap.model.data.descriptors names
        sd = blob["state_dict"]
        self.descriptor_affine = None  # BatchNorm1d in eval mode as (scale, shift)
        if self.descriptors:
            scale = (sd[f"{_DESCRIPTOR_NORM}.weight"].astype(np.float32)
                     / np.sqrt(sd[f"{_DESCRIPTOR_NORM}.running_var"].astype(np.float32)
                               + np.float32(1e-5)))
            shift = (sd[f"{_DESCRIPTOR_NORM}.bias"].astype(np.float32)
                     - sd[f"{_DESCRIPTOR_NORM}.running_mean"].astype(np.float32) * scale)
            self.descriptor_affine = (scale, shift)
        self.convs = []  # (weight, shift): conv by the weight, then + shift
        for conv, bn in _conv_names(self.norm):
            w = np.ascontiguousarray(sd[f"{conv}.weight"], np.float32)
            if bn is None:
                self.convs.append((w, np.ascontiguousarray(sd[f"{conv}.bias"], np.float32)))
            else:  # BatchNorm2d in eval mode (eps 1e-5): (y - mean) / sqrt(var + eps) * g + b,
                # its per-channel scale folded into the convolution's weights
                scale = (sd[f"{bn}.weight"].astype(np.float32)
                         / np.sqrt(sd[f"{bn}.running_var"].astype(np.float32) + np.float32(1e-5)))
                shift = (sd[f"{bn}.bias"].astype(np.float32)
                         - sd[f"{bn}.running_mean"].astype(np.float32) * scale)
                self.convs.append((np.ascontiguousarray(w * scale[:, None, None, None]),
                                   shift.astype(np.float32)))
        self.linears = [(np.ascontiguousarray(sd[f"{k}.weight"].T, np.float32),
                         np.ascontiguousarray(sd[f"{k}.bias"], np.float32)) for k in _LINEAR]
        self.threshold = float(blob["threshold"])
        self.temperature = float((blob.get("calibration") or {}).get("temperature", 1.0))
        self.trials = int((blob.get("training") or {}).get("trials", 100))
        self.data_fingerprint = str(blob["data_fingerprint"])
        self.assemblies = list(blob["assemblies"])
        self.image_stats = dict(blob["image_stats"])
        self.metrics = dict(blob.get("metrics") or {})
        size = int(cfg["image_size"])
        self.image_shape = (int(cfg["in_channels"]), size, size)

    def _logits(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        x = images.transpose(0, 2, 3, 1).astype(np.float32) / np.float32(255.0)  # NHWC
        for w, shift in self.convs:
            x = _pool_relu(_conv_nhwc(x, w, self.padding, even=True), shift)
        x = x.transpose(0, 3, 1, 2).reshape(len(x), -1)  # torch's Flatten: C, H, W order
        if self.descriptor_affine is not None:
            scale, shift = self.descriptor_affine
            x = np.concatenate([x, descriptors.astype(np.float32) * scale + shift], axis=1)
        for i, (w, b) in enumerate(self.linears):
            x = x @ w + b
            if i < len(self.linears) - 1:
                np.maximum(x, 0.0, out=x)
        return x

    def outputs(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        """The network's raw outputs (float64 [N, 2] or [N, 1]) for uint8 images (checked), with
        the operations' descriptors float [N, k] when the network takes them."""
        images = np.asarray(images)
        if images.dtype != np.uint8 or images.ndim != 4 or images.shape[1:] != self.image_shape:
            raise ValueError(f"images must be uint8 [N, {', '.join(map(str, self.image_shape))}], "
                             f"got {images.dtype} {list(images.shape)}")
        k = len(self.descriptors)
        if k and (descriptors is None or np.shape(descriptors) != (len(images), k)):
            raise ValueError(f"this model takes descriptors float [N, {k}] beside the images")
        width = 2 if self.head == "class" else 1
        out = np.zeros((len(images), width), dtype=np.float64)
        for i in range(0, len(images), CHUNK):
            d = None if not k else np.asarray(descriptors[i:i + CHUNK])
            out[i:i + CHUNK] = self._logits(images[i:i + CHUNK], d)
            if self.mirror:  # rap.model.inference.torch_engine.mirrored, without importing torch
                flipped = np.ascontiguousarray(images[i:i + CHUNK, ..., ::-1])
                out[i:i + CHUNK] += self._logits(flipped, d)
                out[i:i + CHUNK] /= 2
        return out

    def prob_high(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        """P(high) for uint8 [N, 2, 64, 64] -> float64 [N], through the checkpoint's head and
        temperature as ``rap.model.network.heads.prob_high`` computes it (float32 result, like torch's)."""
        return self._prob_high(self.outputs(images, descriptors))

    def expected_score(self, images: np.ndarray, descriptors: np.ndarray | None = None
                       ) -> np.ndarray:
        """The expected success rate (binomial head; P(high) for the class head), float64 [N]."""
        return self._expected(self.outputs(images, descriptors))

    def prob_high_and_expected(self, images: np.ndarray, descriptors: np.ndarray | None = None
                               ) -> tuple[np.ndarray, np.ndarray]:
        """``(prob_high, expected_score)`` from one forward pass (what RAP ranks by)."""
        z = self.outputs(images, descriptors)
        return self._prob_high(z), self._expected(z)

    def _prob_high(self, z: np.ndarray) -> np.ndarray:
        t = self.temperature
        if self.head == "class":
            return _softmax_high(z.astype(np.float32) / np.float32(t))
        p = 1.0 / (1.0 + np.exp(-(z[:, 0] / t)))
        k = _high_count(self.threshold, self.trials)
        return _binomial_tail(p, self.trials, k).astype(np.float32).astype(np.float64)

    def _expected(self, z: np.ndarray) -> np.ndarray:
        if self.head == "class":
            return _softmax_high(z.astype(np.float32) / np.float32(self.temperature))
        zt = z[:, 0].astype(np.float32) / np.float32(self.temperature)
        return (np.float32(1.0) / (np.float32(1.0) + np.exp(-zt))).astype(np.float64)

    def is_high(self, images: np.ndarray, descriptors: np.ndarray | None = None) -> np.ndarray:
        return self.prob_high(images, descriptors) >= 0.5


def _softmax_high(z: np.ndarray) -> np.ndarray:
    z = z - z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return (e[:, 1] / e.sum(axis=1)).astype(np.float64)


def _high_count(threshold: float, trials: int) -> int:
    return max(0, math.ceil(threshold * trials - 1e-9))  # rap.model.network.heads.high_count


def _binomial_tail(p: np.ndarray, n: int, k: int) -> np.ndarray:
    """P(Bin(n, p) >= k) in float64, summed in log space like ``rap.model.network.heads.binomial_tail``."""
    if k <= 0:
        return np.ones_like(p)
    if k > n:
        return np.zeros_like(p)
    p = np.clip(p, 1e-12, 1 - 1e-12)
    lp, lq = np.log(p), np.log1p(-p)
    terms = np.stack([math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1)
                      + j * lp + (n - j) * lq for j in range(k, n + 1)])
    m = terms.max(axis=0)
    return np.clip(np.exp(m + np.log(np.exp(terms - m).sum(axis=0))), 0.0, 1.0)


binomial_tail = _binomial_tail  # public names for the other numpy heads (descriptor_model)
high_count = _high_count


def _conv_names(norm: str) -> list[tuple[str, str | None]]:
    """(convolution, batch norm or None) module names of the four stages."""
    step = 4 if norm == "batch" else 3
    return [(f"features.{i * step}", f"features.{i * step + 1}" if norm == "batch" else None)
            for i in range(4)]


def _supported(blob) -> bool:
    """Exactly the architectures of ``RobustnessCNN`` this module runs, with consistent shapes."""
    try:
        if not isinstance(blob, dict) or blob.get("format") != _FORMAT:
            return False
        if blob.get("format_version") != _FORMAT_VERSION:
            return False
        cfg, sd = blob["config"], blob["state_dict"]
        if not _CONFIG_KEYS <= set(cfg) <= _CONFIG_KEYS | _OPTIONAL_KEYS:
            return False
        norm, head = cfg.get("norm", "none"), cfg.get("head", "class")
        if norm not in ("none", "batch") or head not in ("class", "binomial"):
            return False
        if cfg.get("view", "pair") not in ("pair", "pair+crop"):
            return False
        if len(cfg["channels"]) != 4 or len(cfg["hidden"]) != 3 or int(cfg["n_classes"]) != 2:
            return False
        t = (blob.get("calibration") or {}).get("temperature", 1.0)
        if not (isinstance(t, (int, float)) and t > 0):
            return False
        descriptors = cfg.get("descriptors", [])
        if not isinstance(descriptors, (list, tuple)) or not all(isinstance(d, str)
                                                                 for d in descriptors):
            return False
        want = {f"{k}.{p}" for k in _LINEAR for p in ("weight", "bias")}
        if descriptors:
            want |= {f"{_DESCRIPTOR_NORM}.{p}" for p in ("weight", "bias", "running_mean",
                                                         "running_var", "num_batches_tracked")}
            if any(sd[f"{_DESCRIPTOR_NORM}.{p}"].shape != (len(descriptors),)
                   for p in ("weight", "bias", "running_mean", "running_var")):
                return False
        for conv, bn in _conv_names(norm):
            want.add(f"{conv}.weight")
            if bn is None:
                want.add(f"{conv}.bias")
            else:
                want |= {f"{bn}.{p}" for p in ("weight", "bias", "running_mean", "running_var",
                                                "num_batches_tracked")}
        if set(sd) != want:
            return False
        k, pad, c_in = int(cfg["kernel_size"]), int(cfg["padding"]), int(cfg["in_channels"])
        side = int(cfg["image_size"])
        for (conv, bn), c_out in zip(_conv_names(norm), cfg["channels"]):
            if sd[f"{conv}.weight"].shape != (c_out, c_in, k, k):
                return False
            vectors = [f"{conv}.bias"] if bn is None else [
                f"{bn}.{p}" for p in ("weight", "bias", "running_mean", "running_var")]
            if any(sd[v].shape != (c_out,) for v in vectors):
                return False
            c_in, side = c_out, (side + 2 * pad - k + 1) // 2
        width = c_in * side * side + len(descriptors)
        outs = 2 if head == "class" else 1
        for name, h in zip(_LINEAR, [*cfg["hidden"], outs]):
            if sd[f"{name}.weight"].shape != (h, width) or sd[f"{name}.bias"].shape != (h,):
                return False
            width = h
        return all(v.dtype == np.float32 for name, v in sd.items()
                   if not name.endswith("num_batches_tracked"))
    except (KeyError, TypeError, ValueError, AttributeError):
        return False


def load_numpy_predictor(path: str | Path) -> NumpyPredictor | None:
    """A ``NumpyPredictor`` for the checkpoint at ``path``, or None when this module cannot run it
    exactly (the caller then loads it with torch, which also reports a bad file)."""
    try:
        blob = read_torch_checkpoint(path)
    except Exception:  # unreadable here: let rap.model.network.checkpoint say what is wrong
        return None
    return NumpyPredictor(blob, str(path)) if _supported(blob) else None
