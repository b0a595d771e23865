"""Training data from the Arrow dataset: row selection, labels, shuffled uint8 batches, summaries.

Images stay uint8 ([2, 64, 64], 8 KiB a row) until a batch is handed to the network, which scales
it on the device. A selection that fits in ``max_memory_mb`` is read once into one uint8 array and
shuffled each epoch by a seeded permutation of row indices (``InMemoryBatches``); a larger one is
streamed every epoch, shards in a seeded order through a seeded shuffle buffer
(``StreamingBatches``). Both are reproducible for a given ``numpy.random.Generator`` and yield
``(images, labels, successes, trials)`` batches, followed by the rows' geometric descriptors
(``rap.model.data.descriptors``) when a ``RowStore`` was given them (``with_descriptors``; in memory
only). ``RowStore`` holds a whole dataset in memory
once, so that many folds (cross-validation, ablations) select rows by index without reading the
shards again.

Rows are selected by assembly and by family (``Selection``); schema-1 rows, which have no family,
count as family ``custom``. A key stored more than once (``rap.dataset.duplicate_keys``) is one
row everywhere here: its first, by shard path and then row; a shard that does not read raises
``rap.dataset.CorruptShardError`` (one line naming it).

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

from rap.dataset import (IMAGE_BYTES, count_rows, decode_images, duplicate_keys, iter_batches,
                         iter_shard_batches, open_dataset, read_meta, read_table)
from rap.errors import InputError

__all__ = ["Selection", "select", "labels_of", "data_fingerprint", "assembly_summary",
           "image_stats", "InMemoryBatches", "StreamingBatches", "make_batches", "iter_rows",
           "RowStore", "LABEL_COLUMNS"]

LABEL_COLUMNS = ("score", "successes", "trials", "image")
_SHARD_BATCH_ROWS = 1 << 17  # pyarrow's default: the streamed epochs' order as before


@dataclass(frozen=True)
class Selection:
    """Rows of a dataset chosen by assembly and family: ``include`` (None = all) minus
    ``exclude``, restricted to ``families`` (None = all) minus ``exclude_families``."""

    root: str
    include: tuple[str, ...] | None = None
    exclude: tuple[str, ...] = ()
    families: tuple[str, ...] | None = None
    exclude_families: tuple[str, ...] = ()

    @property
    def filter(self) -> pads.Expression | None:
        expr = None

        def both(e):
            return e if expr is None else expr & e

        if self.include is not None:
            expr = both(pc.field("assembly").isin(list(self.include)))
        if self.exclude:
            expr = both(~pc.field("assembly").isin(list(self.exclude)))
        fam = pc.if_else(pc.field("family").is_null(), "custom", pc.field("family"))
        if self.families is not None:
            expr = both(fam.isin(list(self.families)))
        if self.exclude_families:
            expr = both(~fam.isin(list(self.exclude_families)))
        return expr

    def count(self) -> int:
        return count_rows(self.root, filter=self.filter, unique=True)


def select(root: str | Path, *, include=None, exclude=(), families=None,
           exclude_families=()) -> Selection:
    return Selection(str(root), tuple(include) if include is not None else None, tuple(exclude),
                     tuple(families) if families is not None else None, tuple(exclude_families))


def labels_of(scores: np.ndarray, threshold: float) -> np.ndarray:
    """Class index per row: 1 (high) where score >= threshold, else 0."""
    return (np.asarray(scores) >= threshold).astype(np.int64)


def data_fingerprint(sel: Selection) -> str:
    """Hex SHA-256 of the selected rows' sorted content keys plus the dataset metadata."""
    keys = read_table(sel.root, columns=["key"], filter=sel.filter, unique=True).column("key")
    h = hashlib.sha256()
    meta = read_meta(sel.root)
    h.update(json.dumps(meta.__dict__ if meta else None, sort_keys=True).encode())
    for k in sorted(keys.to_pylist()):
        h.update(k.encode())
        h.update(b"\n")
    return h.hexdigest()


def assembly_summary(sel: Selection, threshold: float) -> list[dict]:
    """Per assembly in the selection: name, geometry hash(es), rows, fraction of high rows."""
    t = read_table(sel.root, columns=["assembly", "geometry_hash", "score"], filter=sel.filter,
                   unique=True).to_pandas()
    out = []
    for name, g in t.groupby("assembly", sort=True):
        hashes = sorted(set(g["geometry_hash"]))
        out.append({"name": str(name), "geometry_hash": hashes[0] if len(hashes) == 1 else hashes,
                    "rows": int(len(g)),
                    "high_fraction": float(labels_of(g["score"].to_numpy(), threshold).mean())})
    return out


def iter_rows(sel: Selection, batch_size: int = 256,
              columns=("score", "image")) -> Iterator[tuple[np.ndarray, ...]]:
    """(uint8 images [n, 2, 64, 64], then the other ``columns`` in order) batches of the
    selection, in dataset order; by default (images, scores)."""
    others = [c for c in columns if c != "image"]
    for rb in iter_batches(sel.root, columns=[*others, "image"], batch_size=batch_size,
                           filter=sel.filter, unique=True):
        if rb.num_rows:
            yield (decode_images(rb.column("image")), *(rb.column(c).to_numpy() for c in others))


def image_stats(batches) -> dict:
    """Summary of uint8 image batches [n, C, 64, 64]: per channel, mean intensity (0..1) and the
    mean and standard deviation over images of the foreground fraction (pixels > 0); a coarse 8x8
    mean foreground image per channel. The planner compares new images against these."""
    n = 0
    fg_sum = fg_sq = inten = coarse = None
    for images in batches:
        k, c, hgt, wid = images.shape
        if fg_sum is None:
            fg_sum, fg_sq, inten, coarse = np.zeros(c), np.zeros(c), np.zeros(c), np.zeros((c, 8, 8))
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
    """Rows in one uint8 array; each epoch a seeded permutation of them, in key order (``index``:
    row i is ``images[index[i]]``). Built from a selection (read once) or from a ``RowStore`` and
    row indices (``from_store``: no copy of the images)."""

    def __init__(self, sel: Selection | None, threshold: float, batch_size: int):
        self.batch_size = batch_size
        self.index = None
        self.descriptors = None  # float32 [N, k] in the order of labels, when given
        if sel is None:
            return
        n = sel.count()
        self.images = np.empty((n, 2, 64, 64), dtype=np.uint8)
        self.labels = np.empty(n, dtype=np.int64)
        self.successes = np.empty(n, dtype=np.int64)
        self.trials = np.empty(n, dtype=np.int64)
        keys = np.empty(n, dtype=object)
        i = 0
        for rb in iter_batches(sel.root, columns=[*LABEL_COLUMNS, "key"], filter=sel.filter,
                               unique=True):
            k = rb.num_rows
            if not k:
                continue
            self.images[i:i + k] = decode_images(rb.column("image"))
            self.labels[i:i + k] = labels_of(rb.column("score").to_numpy(), threshold)
            self.successes[i:i + k] = rb.column("successes").to_numpy()
            self.trials[i:i + k] = rb.column("trials").to_numpy()
            keys[i:i + k] = rb.column("key").to_pylist()
            i += k
        assert i == n, "dataset changed while reading"
        # key order, as RowStore: the same rows, the same run. The images stay as read and are
        # gathered through the order (no second copy of them); the small columns are reordered.
        self.index = np.argsort(keys, kind="stable")
        self.labels, self.successes = self.labels[self.index], self.successes[self.index]
        self.trials = self.trials[self.index]

    @classmethod
    def from_store(cls, store: "RowStore", index: np.ndarray, threshold: float,
                   batch_size: int) -> "InMemoryBatches":
        b = cls(None, threshold, batch_size)
        b.index = np.sort(np.asarray(index, dtype=np.int64))
        b.images = store.images  # gathered per batch through the index
        b.labels = labels_of(store.scores[b.index], threshold)
        b.successes = store.successes[b.index]
        b.trials = store.trials[b.index]
        if store.descriptors is not None:
            b.descriptors = store.descriptors[b.index]
        return b

    def __len__(self) -> int:
        return len(self.labels)

    def class_counts(self) -> np.ndarray:
        return np.bincount(self.labels, minlength=2)

    def image_batches(self, size: int = 1024) -> Iterator[np.ndarray]:
        """The images in row order (for statistics)."""
        for s in range(0, len(self.labels), size):
            yield (self.images[s:s + size] if self.index is None
                   else self.images[self.index[s:s + size]])

    def epoch(self, rng: np.random.Generator) -> Iterator[tuple[np.ndarray, ...]]:
        order = rng.permutation(len(self.labels))
        for s in range(0, len(order), self.batch_size):
            idx = np.sort(order[s:s + self.batch_size])  # sorted gather: faster, same batch
            rows = idx if self.index is None else self.index[idx]
            batch = (self.images[rows], self.labels[idx], self.successes[idx], self.trials[idx])
            yield batch if self.descriptors is None else batch + (self.descriptors[idx],)


class StreamingBatches:
    """The selection streamed each epoch: shard files in a seeded order, rows through a seeded
    shuffle buffer of ``buffer_rows``; never more than the buffer in memory."""

    def __init__(self, sel: Selection, threshold: float, batch_size: int, buffer_rows: int):
        self.sel = sel
        self.threshold = threshold
        self.batch_size = batch_size
        self.buffer_rows = max(buffer_rows, batch_size)
        self.files = sorted(open_dataset(sel.root).files)
        self.duplicates = duplicate_keys(sel.root)
        t = read_table(sel.root, columns=["score", "trials"], filter=sel.filter, unique=True)
        self.labels_all = labels_of(t.column("score").to_numpy(), threshold)
        self.trials = t.column("trials").to_numpy().astype(np.int64)
        self.index = None

    def __len__(self) -> int:
        return len(self.labels_all)

    def class_counts(self) -> np.ndarray:
        return np.bincount(self.labels_all, minlength=2)

    def image_batches(self, size: int = 1024) -> Iterator[np.ndarray]:
        for images, _ in iter_rows(self.sel, batch_size=size):
            yield images

    def epoch(self, rng: np.random.Generator) -> Iterator[tuple[np.ndarray, ...]]:
        parts: list[list[np.ndarray]] = [[], [], [], []]  # images, labels, successes, trials
        held = 0

        def emit_from(order, upto):
            cat = [np.concatenate(p) for p in parts]
            for s in range(0, upto, self.batch_size):
                idx = order[s:s + self.batch_size]
                yield tuple(c[idx] for c in cat)
            rest = order[upto:]
            return [[c[rest]] for c in cat], len(rest)

        for f in rng.permutation(len(self.files)):
            for rb in iter_shard_batches(self.files[f], list(LABEL_COLUMNS), _SHARD_BATCH_ROWS,
                                         self.sel.filter, self.duplicates, self.sel.root):
                if not rb.num_rows:
                    continue
                parts[0].append(decode_images(rb.column("image")).copy())
                parts[1].append(labels_of(rb.column("score").to_numpy(), self.threshold))
                parts[2].append(rb.column("successes").to_numpy().astype(np.int64))
                parts[3].append(rb.column("trials").to_numpy().astype(np.int64))
                held += rb.num_rows
                if held >= self.buffer_rows:
                    order = rng.permutation(held)
                    emit = held - self.buffer_rows // 2  # emit whole batches, keep half a buffer
                    emit -= emit % self.batch_size
                    parts, held = yield from emit_from(order, emit)
        if held:
            parts, held = yield from emit_from(rng.permutation(held), held)


def make_batches(sel: Selection, threshold: float, batch_size: int, max_memory_mb: float):
    """In memory when the selection's uint8 images fit in ``max_memory_mb``, else streamed."""
    n = sel.count()
    if n == 0:
        raise InputError(f"{sel.root}: no training rows selected")
    if n * IMAGE_BYTES <= max_memory_mb * 2 ** 20:
        return InMemoryBatches(sel, threshold, batch_size)
    buffer_rows = max(int(max_memory_mb * 2 ** 20 // IMAGE_BYTES) // 2, batch_size)
    return StreamingBatches(sel, threshold, batch_size, buffer_rows)


class RowStore:
    """A whole dataset's labelled rows in memory, read once: uint8 images [N, 2, 64, 64], scores,
    successes, trials, and per row its key, assembly and family (``custom`` for schema-1 rows).
    ``index(...)`` selects rows the way ``Selection`` does, as a sorted index array. Memory: about
    8.2 KiB a row."""

    def __init__(self, root: str | Path, order: str = "key"):
        """``order``: rows sorted by key (the default: training then depends on the rows, not
        on the order the farm committed its shards) or ``"dataset"``, as read (the order the
        models of docs/RESULTS.md so far were trained in; ``research/ablation.py`` keeps it, so
        that its table's rows sample the same training rows)."""
        if order not in ("key", "dataset"):
            raise ValueError(f"order {order!r}: key or dataset")
        self.root = str(Path(root).resolve())
        t = read_table(self.root, unique=True, columns=[
            "key", "assembly", "geometry_hash", "family", "score", "successes", "trials", "moving",
            "fixed", "direction_x", "direction_y", "image"])
        # rows in key order, not in the order the farm's workers happened to commit shards, so
        # that seeded training is the same for the same rows
        keys = np.array(t.column("key").to_pylist(), dtype=object)
        perm = np.argsort(keys, kind="stable") if order == "key" else np.arange(len(keys))
        self.keys = keys[perm]
        self.images = decode_images(t.column("image"))[perm]
        self.scores = t.column("score").to_numpy()[perm]
        self.successes = t.column("successes").to_numpy().astype(np.int64)[perm]
        self.trials = t.column("trials").to_numpy().astype(np.int64)[perm]
        self.assembly = np.array(t.column("assembly").to_pylist(), dtype=object)[perm]
        self.geometry_hash = np.array(t.column("geometry_hash").to_pylist(), dtype=object)[perm]
        self.moving = np.array(t.column("moving").to_pylist(), dtype=object)[perm]
        self.fixed = np.array(t.column("fixed").to_pylist(), dtype=object)[perm]
        self.direction = np.stack([t.column("direction_x").to_numpy(),
                                   t.column("direction_y").to_numpy()], axis=1)[perm]
        self.view_name = "pair"
        self._views: dict[str, "RowStore"] = {}
        self.descriptors = None  # float32 [N, k]: ``with_descriptors``
        fam = pc.if_else(pc.is_null(t.column("family")), "custom", t.column("family"))
        self.family = np.array(fam.to_pylist(), dtype=object)[perm]

    def __len__(self) -> int:
        return len(self.scores)

    def view(self, view: str, progress=None) -> "RowStore":
        """The same rows with the images of ``view`` (``rap.model.data.views``): the stored pair, or
        the pair followed by channels rendered again from the geometry (made once, cached;
        ``progress(done, total)`` while rendering)."""
        if view == self.view_name:
            return self
        if view not in self._views:
            import copy

            from rap.model.data.views import extra_channels

            extra = extra_channels(self, view, progress)
            other = copy.copy(self)
            other.images = np.concatenate([self.images, extra], axis=1)
            other.view_name = view
            other._views = {}
            self._views[view] = other
        return self._views[view]

    def with_descriptors(self, names: tuple[str, ...], progress=None) -> "RowStore":
        """The same rows (and images) with the geometric descriptors ``names`` of each
        (``rap.model.data.views.descriptor_columns``: computed from the geometry once, cached)."""
        if not names:
            return self
        import copy

        from rap.model.data.views import descriptor_columns

        other = copy.copy(self)
        other.descriptors = descriptor_columns(self, tuple(names), progress)
        other._views = {}
        return other

    def index(self, sel: Selection) -> np.ndarray:
        mask = np.ones(len(self), dtype=bool)
        if sel.include is not None:
            mask &= np.isin(self.assembly, list(sel.include))
        if sel.exclude:
            mask &= ~np.isin(self.assembly, list(sel.exclude))
        if sel.families is not None:
            mask &= np.isin(self.family, list(sel.families))
        if sel.exclude_families:
            mask &= ~np.isin(self.family, list(sel.exclude_families))
        return np.flatnonzero(mask)

    def fingerprint(self, index: np.ndarray) -> str:
        """``data_fingerprint`` of the rows at ``index`` (same value as for the selection)."""
        h = hashlib.sha256()
        meta = read_meta(self.root)
        h.update(json.dumps(meta.__dict__ if meta else None, sort_keys=True).encode())
        for k in sorted(self.keys[index].tolist()):
            h.update(k.encode())
            h.update(b"\n")
        return h.hexdigest()

    def summary(self, index: np.ndarray, threshold: float) -> list[dict]:
        """``assembly_summary`` of the rows at ``index``."""
        out = []
        names = self.assembly[index]
        hashes = self.geometry_hash[index]
        labels = labels_of(self.scores[index], threshold)
        for name in sorted(set(names.tolist())):
            m = names == name
            hs = sorted(set(hashes[m].tolist()))
            out.append({"name": str(name), "geometry_hash": hs[0] if len(hs) == 1 else hs,
                        "rows": int(m.sum()), "high_fraction": float(labels[m].mean())})
        return out
