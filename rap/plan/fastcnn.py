"""Torch-free inference of the robustness CNN, so that a one-off ``rap-farm plan`` starts quickly.

Importing torch takes 2-4 s on a 2-core machine, more than planning a 7-part assembly; loading a
checkpoint through ``rap.model`` adds pyarrow and pandas. This module reads the same checkpoint file
(``rap.model.checkpoint``: a ``torch.save`` zip archive of plain values and tensors) with the
standard library and numpy, and runs the forward pass of ``rap.model.cnn.RobustnessCNN`` in numpy:
four (4x4 convolution, ReLU, 2x2 max-pooling) stages, three (linear, ReLU) layers (dropout is the
identity at inference), a final linear layer and the softmax probability of "high".

Contract:

* ``load_fast_predictor(path)`` returns a ``FastPredictor`` (``prob_high(images)``, ``threshold``,
  ``assemblies``, ``image_stats``, ``data_fingerprint``, like ``rap.model.predict.Predictor``), or
  ``None`` when the file is not exactly the architecture above (other config fields, other layer
  names or shapes, other pickled objects): the caller then loads it with torch. Nothing in the file
  is executed; the unpickler admits three globals (``OrderedDict``, torch's tensor rebuild
  function and storage types), which it maps to numpy.
* Results equal torch's to float32 rounding (about 1e-6 in P(high));
  ``tests/plan/test_fastcnn.py`` compares both on the shipped model and on a freshly built network,
  so a change of ``RobustnessCNN`` that this module does not follow fails there.

Cost: about 26 M multiply-adds per image pair (matmuls over NHWC arrays), ~6 ms per image on 2 cores\n(torch: ~4 ms),
batches of ``CHUNK`` images at a time to bound memory. No torch, no ray, no pyarrow.
"""

from __future__ import annotations

import pickle
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

__all__ = ["FastPredictor", "load_fast_predictor", "read_torch_checkpoint", "CHUNK"]

CHUNK = 64  # images per forward pass (memory: ~40 MB of im2col buffers at 64)

_FORMAT = "rap-farm/robustness-cnn"
_FORMAT_VERSION = 1
_CONFIG_KEYS = {"in_channels", "image_size", "channels", "kernel_size", "padding", "hidden",
                "dropout", "n_classes"}
_CONV = ("features.0", "features.3", "features.6", "features.9")
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


def _relu_pool(y: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bias + ReLU + MaxPool2d(2) (floor) on NHWC float32."""
    y += b
    np.maximum(y, 0.0, out=y)
    n, ho, wo, o = y.shape
    h2, w2 = ho // 2, wo // 2
    return y[:, :2 * h2, :2 * w2].reshape(n, h2, 2, w2, 2, o).max(axis=(2, 4))


def _conv_im2col(x: np.ndarray, w: np.ndarray, pad: int) -> np.ndarray:
    """Conv2d (stride 1, zero padding) of NCHW input by im2col: NHWC output. For few channels."""
    n, c, _, _ = x.shape
    o, _, kh, kw = w.shape
    xp = np.pad(x, ((0, 0), (0, 0), (pad, pad), (pad, pad)))
    win = np.lib.stride_tricks.sliding_window_view(xp, (kh, kw), axis=(2, 3))  # N C Ho Wo kh kw
    ho, wo = win.shape[2], win.shape[3]
    cols = win.transpose(0, 2, 3, 1, 4, 5).reshape(n * ho * wo, c * kh * kw)
    return (cols @ w.reshape(o, c * kh * kw).T).reshape(n, ho, wo, o)


def _conv_nhwc(x: np.ndarray, w: np.ndarray, pad: int) -> np.ndarray:
    """Conv2d (stride 1, zero padding) of NHWC input by im2col with (kh, kw, C) columns, filled by
    kh*kw contiguous slice copies: NHWC output."""
    n, h, wd, c = x.shape
    o, _, kh, kw = w.shape
    xp = np.pad(x, ((0, 0), (pad, pad), (pad, pad), (0, 0)))
    ho, wo = h + 2 * pad - kh + 1, wd + 2 * pad - kw + 1
    cols = np.empty((n, ho, wo, kh, kw, c), np.float32)
    for i in range(kh):
        for j in range(kw):
            cols[:, :, :, i, j, :] = xp[:, i:i + ho, j:j + wo, :]
    wm = w.transpose(0, 2, 3, 1).reshape(o, kh * kw * c)
    return (cols.reshape(n * ho * wo, kh * kw * c) @ wm.T).reshape(n, ho, wo, o)


class FastPredictor:
    """P(high) of image pairs with a checkpoint's weights, in numpy (see module doc)."""

    engine = "numpy"

    def __init__(self, blob: dict, path: str = ""):
        cfg = blob["config"]
        self.config = dict(cfg)
        self.path = path
        self.padding = int(cfg["padding"])
        sd = blob["state_dict"]
        self.convs = [(np.ascontiguousarray(sd[f"{k}.weight"], np.float32),
                       np.ascontiguousarray(sd[f"{k}.bias"], np.float32)) for k in _CONV]
        self.linears = [(np.ascontiguousarray(sd[f"{k}.weight"].T, np.float32),
                         np.ascontiguousarray(sd[f"{k}.bias"], np.float32)) for k in _LINEAR]
        self.threshold = float(blob["threshold"])
        self.data_fingerprint = str(blob["data_fingerprint"])
        self.assemblies = list(blob["assemblies"])
        self.image_stats = dict(blob["image_stats"])
        self.metrics = dict(blob.get("metrics") or {})
        size = int(cfg["image_size"])
        self.image_shape = (int(cfg["in_channels"]), size, size)

    def _logits(self, images: np.ndarray) -> np.ndarray:
        x = images.astype(np.float32) / np.float32(255.0)
        (w0, b0), *rest = self.convs
        x = _relu_pool(_conv_im2col(x, w0, self.padding), b0)
        for w, b in rest:
            x = _relu_pool(_conv_nhwc(x, w, self.padding), b)
        x = x.transpose(0, 3, 1, 2).reshape(len(x), -1)  # torch's Flatten: C, H, W order
        for i, (w, b) in enumerate(self.linears):
            x = x @ w + b
            if i < len(self.linears) - 1:
                np.maximum(x, 0.0, out=x)
        return x

    def prob_high(self, images: np.ndarray) -> np.ndarray:
        """P(high) for uint8 [N, 2, 64, 64] -> float64 [N]: softmax of the logits, class 1."""
        images = np.asarray(images)
        if images.dtype != np.uint8 or images.ndim != 4 or images.shape[1:] != self.image_shape:
            raise ValueError(f"images must be uint8 [N, {', '.join(map(str, self.image_shape))}], "
                             f"got {images.dtype} {list(images.shape)}")
        out = np.zeros(len(images), dtype=np.float64)
        for i in range(0, len(images), CHUNK):
            z = self._logits(images[i:i + CHUNK])
            z = z - z.max(axis=1, keepdims=True)
            e = np.exp(z)
            out[i:i + CHUNK] = (e[:, 1] / e.sum(axis=1)).astype(np.float64)
        return out


def _supported(blob) -> bool:
    """Exactly the architecture of the module doc, with consistent shapes."""
    try:
        if not isinstance(blob, dict) or blob.get("format") != _FORMAT:
            return False
        if blob.get("format_version") != _FORMAT_VERSION:
            return False
        cfg, sd = blob["config"], blob["state_dict"]
        if set(cfg) != _CONFIG_KEYS or len(cfg["channels"]) != 4 or len(cfg["hidden"]) != 3:
            return False
        want = {f"{k}.{p}" for k in _CONV + _LINEAR for p in ("weight", "bias")}
        if set(sd) != want:
            return False
        k, pad, c_in = int(cfg["kernel_size"]), int(cfg["padding"]), int(cfg["in_channels"])
        side = int(cfg["image_size"])
        for name, c_out in zip(_CONV, cfg["channels"]):
            if sd[f"{name}.weight"].shape != (c_out, c_in, k, k) or sd[f"{name}.bias"].shape != (c_out,):
                return False
            c_in, side = c_out, (side + 2 * pad - k + 1) // 2
        width = c_in * side * side
        for name, h in zip(_LINEAR, [*cfg["hidden"], cfg["n_classes"]]):
            if sd[f"{name}.weight"].shape != (h, width) or sd[f"{name}.bias"].shape != (h,):
                return False
            width = h
        return int(cfg["n_classes"]) == 2 and all(
            v.dtype == np.float32 for v in sd.values())
    except (KeyError, TypeError, ValueError, AttributeError):
        return False


def load_fast_predictor(path: str | Path) -> FastPredictor | None:
    """A ``FastPredictor`` for the checkpoint at ``path``, or None when this module cannot run it
    exactly (the caller then loads it with torch, which also reports a bad file)."""
    try:
        blob = read_torch_checkpoint(path)
    except Exception:  # unreadable here: let rap.model.checkpoint say what is wrong
        return None
    return FastPredictor(blob, str(path)) if _supported(blob) else None
