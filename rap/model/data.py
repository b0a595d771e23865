"""Training data from the Arrow dataset: row selection, labels, shuffled uint8 batches, summaries.

Images stay uint8 ([2, 64, 64], 8 KiB a row) until a batch is handed to the network, which scales
it on the device. A selection that fits in ``max_memory_mb`` is read once into one uint8 array and
shuffled each epoch by a seeded permutation of row indices (``InMemoryBatches``); a larger one is
streamed every epoch, shards in a seeded order through a seeded shuffle buffer
(``StreamingBatches``). Both are reproducible for a given ``numpy.random.Generator``.

Labels: 1 ("high") when ``score >= threshold``, else 0; the threshold is a parameter, stored in the
checkpoint, never a literal here.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import pyarrow.compute as pc
import pyarrow.dataset as pads

from rap.dataset import IMAGE_BYTES, decode_images, iter_batches, open_dataset, read_meta
from rap.errors import InputError

__all__ = ["Selection", "select", "labels_of", "data_fingerprint", "assembly_summary",
           "image_stats", "InMemoryBatches", "StreamingBatches", "make_batches", "iter_rows"]


@dataclass(frozen=True)
class Selection:
    """Rows of a dataset chosen by assembly: ``include`` (None = all) minus ``exclude``."""

    root: str
    include: tuple[str, ...] | None = None
    exclude: tuple[str, ...] = ()

    @property
    def filter(self) -> pads.Expression | None:
        expr = None
        if self.include is not None:
            expr = pc.field("assembly").isin(list(self.include))
        if self.exclude:
            ex = ~pc.field("assembly").isin(list(self.exclude))
            expr = ex if expr is None else expr & ex
        return expr

    def count(self) -> int:
        return open_dataset(self.root).count_rows(filter=self.filter)


def select(root: str | Path, *, include=None, exclude=()) -> Selection:
    return Selection(str(root), tuple(include) if include is not None else None, tuple(exclude))


def labels_of(scores: np.ndarray, threshold: float) -> np.ndarray:
    """Class index per row: 1 (high) where score >= threshold, else 0."""
    return (np.asarray(scores) >= threshold).astype(np.int64)


def data_fingerprint(sel: Selection) -> str:
    """Hex SHA-256 of the selected rows' sorted content keys plus the dataset metadata."""
    keys = open_dataset(sel.root).to_table(columns=["key"], filter=sel.filter).column("key")
    h = hashlib.sha256()
    meta = read_meta(sel.root)
    h.update(json.dumps(meta.__dict__ if meta else None, sort_keys=True).encode())
    for k in sorted(keys.to_pylist()):
        h.update(k.encode())
        h.update(b"\n")
    return h.hexdigest()


def assembly_summary(sel: Selection, threshold: float) -> list[dict]:
    """Per assembly in the selection: name, geometry hash(es), rows, fraction of high rows."""
    t = open_dataset(sel.root).to_table(columns=["assembly", "geometry_hash", "score"],
                                        filter=sel.filter).to_pandas()
    out = []
    for name, g in t.groupby("assembly", sort=True):
        hashes = sorted(set(g["geometry_hash"]))
        out.append({"name": str(name), "geometry_hash": hashes[0] if len(hashes) == 1 else hashes,
                    "rows": int(len(g)),
                    "high_fraction": float(labels_of(g["score"].to_numpy(), threshold).mean())})
    return out


def iter_rows(sel: Selection, batch_size: int = 256,
              columns=("score", "image")) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(uint8 images [n, 2, 64, 64], scores [n]) batches of the selection, in dataset order."""
    for rb in iter_batches(sel.root, columns=list(columns), batch_size=batch_size, filter=sel.filter):
        if rb.num_rows:
            yield decode_images(rb.column("image")), rb.column("score").to_numpy()


def image_stats(batches) -> dict:
    """Summary of uint8 image batches [n, 2, 64, 64]: per channel, mean intensity (0..1) and the
    mean and standard deviation over images of the foreground fraction (pixels > 0); a coarse 8x8
    mean foreground image per channel. The planner compares new images against these."""
    n = 0
    fg_sum = np.zeros(2)
    fg_sq = np.zeros(2)
    inten = np.zeros(2)
    coarse = np.zeros((2, 8, 8))
    for images in batches:
        k, c, hgt, wid = images.shape
        fg = images > 0
        frac = fg.reshape(k, c, -1).mean(axis=2)
        fg_sum += frac.sum(axis=0)
        fg_sq += (frac ** 2).sum(axis=0)
        inten += images.reshape(k, c, -1).mean(axis=2).sum(axis=0) / 255.0
        coarse += fg.reshape(k, c, 8, hgt // 8, 8, wid // 8).mean(axis=(3, 5)).sum(axis=0)
        n += k
    if n == 0:
        raise InputError("no training rows selected")
    mean = fg_sum / n
    std = np.sqrt(np.maximum(fg_sq / n - mean ** 2, 0.0))
    return {"rows": n, "channel_intensity_mean": (inten / n).tolist(),
            "foreground_mean": mean.tolist(), "foreground_std": std.tolist(),
            "coarse_foreground": (coarse / n).round(5).tolist()}


class InMemoryBatches:
    """The selection read once into a uint8 array; each epoch a seeded permutation of its rows."""

    def __init__(self, sel: Selection, threshold: float, batch_size: int):
        n = sel.count()
        self.images = np.empty((n, 2, 64, 64), dtype=np.uint8)
        self.labels = np.empty(n, dtype=np.int64)
        i = 0
        for images, scores in iter_rows(sel):
            k = len(images)
            self.images[i:i + k] = images
            self.labels[i:i + k] = labels_of(scores, threshold)
            i += k
        assert i == n, "dataset changed while reading"
        self.batch_size = batch_size

    def __len__(self) -> int:
        return len(self.labels)

    def class_counts(self) -> np.ndarray:
        return np.bincount(self.labels, minlength=2)

    def epoch(self, rng: np.random.Generator) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        order = rng.permutation(len(self.labels))
        for s in range(0, len(order), self.batch_size):
            idx = np.sort(order[s:s + self.batch_size])  # sorted gather: faster, same batch
            yield self.images[idx], self.labels[idx]


class StreamingBatches:
    """The selection streamed each epoch: shard files in a seeded order, rows through a seeded
    shuffle buffer of ``buffer_rows``; never more than the buffer in memory."""

    def __init__(self, sel: Selection, threshold: float, batch_size: int, buffer_rows: int):
        self.sel = sel
        self.threshold = threshold
        self.batch_size = batch_size
        self.buffer_rows = max(buffer_rows, batch_size)
        self.files = sorted(open_dataset(sel.root).files)
        scores = open_dataset(sel.root).to_table(columns=["score"], filter=sel.filter)
        self.labels_all = labels_of(scores.column("score").to_numpy(), threshold)

    def __len__(self) -> int:
        return len(self.labels_all)

    def class_counts(self) -> np.ndarray:
        return np.bincount(self.labels_all, minlength=2)

    def epoch(self, rng: np.random.Generator) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        imgs: list[np.ndarray] = []
        labs: list[np.ndarray] = []
        held = 0
        for f in rng.permutation(len(self.files)):
            ds = pads.dataset(self.files[f], format="parquet")
            for rb in ds.to_batches(columns=["score", "image"], filter=self.sel.filter):
                if not rb.num_rows:
                    continue
                imgs.append(decode_images(rb.column("image")).copy())
                labs.append(labels_of(rb.column("score").to_numpy(), self.threshold))
                held += rb.num_rows
                if held >= self.buffer_rows:
                    images, labels = np.concatenate(imgs), np.concatenate(labs)
                    order = rng.permutation(held)
                    emit = held - self.buffer_rows // 2  # emit whole batches, keep half a buffer
                    emit -= emit % self.batch_size
                    for s in range(0, emit, self.batch_size):
                        idx = order[s:s + self.batch_size]
                        yield images[idx], labels[idx]
                    rest = order[emit:]
                    imgs, labs, held = [images[rest]], [labels[rest]], len(rest)
        if held:
            images, labels = np.concatenate(imgs), np.concatenate(labs)
            order = rng.permutation(held)
            for s in range(0, held, self.batch_size):
                idx = order[s:s + self.batch_size]
                yield images[idx], labels[idx]


def make_batches(sel: Selection, threshold: float, batch_size: int, max_memory_mb: float):
    """In memory when the selection's uint8 images fit in ``max_memory_mb``, else streamed."""
    n = sel.count()
    if n == 0:
        raise InputError(f"{sel.root}: no training rows selected")
    if n * IMAGE_BYTES <= max_memory_mb * 2 ** 20:
        return InMemoryBatches(sel, threshold, batch_size)
    buffer_rows = max(int(max_memory_mb * 2 ** 20 // IMAGE_BYTES) // 2, batch_size)
    return StreamingBatches(sel, threshold, batch_size, buffer_rows)
