"""Extra input channels a network may be trained on, rendered again from the dataset's geometry.

A dataset stores the start/goal pair (``view="pair"``). The ``"pair+crop"`` view adds the close-up
of the mating region (``rap.render.images.render_crop``), which the dataset does not store: it is
rendered from each row's assembly, found as ``DATASET/_assemblies/NAME.json`` (``rap-farm label``
writes them: ``rap.dataset.write_geometry``; the corpus ships them), else among the packaged
reference assemblies, and checked against the row's geometry hash.
The rendered channels are cached under ``$RAP_CACHE_DIR`` (default ``~/.cache/rap-farm/views``) by
the dataset's content (the keys of its rows), so they are rendered once per dataset version.

Cost: one ``render_crop`` per row (about 1 ms), once; memory 8 KiB per row and extra view.

The geometric descriptors of ``rap.model.data.descriptors`` are made the same way from the same
geometry (``descriptor_columns`` for a ``RowStore``, cached likewise; ``DatasetGeometry`` for rows
streamed in batches): about 0.4 ms a row, 48 bytes.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Callable

import numpy as np

from rap.assembly import SHIPPED_ASSEMBLIES
from rap.errors import InputError

__all__ = ["extra_channels", "descriptor_columns", "DatasetGeometry", "assembly_file", "cache_dir",
           "PROGRESS_ROWS"]

PROGRESS_ROWS = 1024


def cache_dir() -> Path:
    base = os.environ.get("RAP_CACHE_DIR")
    return Path(base) if base else Path.home() / ".cache" / "rap-farm" / "views"


def assembly_file(root: str | Path, name: str) -> Path | None:
    """The JSON file of assembly ``name`` of the dataset at ``root`` (see the module docstring)."""
    p = Path(root) / "_assemblies" / f"{name}.json"
    if p.is_file():
        return p
    p = SHIPPED_ASSEMBLIES / f"{name}.json"
    return p if p.is_file() else None


def _cached(tag: str, store, shape: tuple[int, ...], make: Callable[[], np.ndarray]) -> np.ndarray:
    """``make()``'s array for these rows, kept under ``cache_dir()`` by ``tag`` and the rows' keys
    (written atomically; a cached array of another shape is made again)."""
    h = hashlib.sha256(tag.encode())
    for k in store.keys.tolist():
        h.update(k.encode())
    path = cache_dir() / f"{h.hexdigest()[:24]}.npy"
    if path.is_file():
        arr = np.load(path)
        if arr.shape == shape:
            return arr
    out = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npy")
    np.save(tmp, out)
    tmp.replace(path)
    return out


def extra_channels(store, view: str,
                   progress: Callable[[int, int], None] | None = None) -> np.ndarray | None:
    """uint8 [N, k, 64, 64]: the channels of ``view`` beyond the stored pair, for every row of a
    ``rap.model.data.rows.RowStore`` (None for ``"pair"``). Raises ``InputError`` when a row's assembly
    cannot be found or its geometry differs. ``progress(done, total)`` is called every
    ``PROGRESS_ROWS`` rows rendered (not when the cache has them; about 1 ms a row)."""
    if view == "pair":
        return None
    if view != "pair+crop":
        raise InputError(f"view {view!r}: pair or pair+crop")
    from rap.operation import Operation
    from rap.render.images import render_crop

    def render() -> np.ndarray:
        geometry = DatasetGeometry(store.root, f"render the {view} view")
        out = np.empty((len(store), 2, 64, 64), dtype=np.uint8)
        for i in range(len(store)):
            a = geometry.assembly(store.assembly[i], store.geometry_hash[i])
            op = Operation(frozenset(store.moving[i].split(",")),
                           frozenset(store.fixed[i].split(",")),
                           (float(store.direction[i, 0]), float(store.direction[i, 1])))
            out[i] = render_crop(a, op)
            if progress is not None and ((i + 1) % PROGRESS_ROWS == 0 or i + 1 == len(store)):
                progress(i + 1, len(store))
        return out

    return _cached(view, store, (len(store), 2, 64, 64), render)


class DatasetGeometry:
    """The assemblies of a dataset's rows, loaded once each and checked against the rows' geometry
    hashes, and the descriptors of rows (``rap.model.data.descriptors``)."""

    def __init__(self, root: str | Path, purpose: str = "compute its descriptors"):
        self.root = root
        self.purpose = purpose
        self._assemblies: dict = {}
        self._contexts: dict = {}

    def assembly(self, name: str, geometry_hash: str):
        a = self._assemblies.get(name)
        if a is None:
            from rap.io import load_assembly

            f = assembly_file(self.root, name)
            if f is None:
                raise InputError(f"{self.root}: no geometry for assembly {name!r} to "
                                 f"{self.purpose}: expected _assemblies/{name}.json (rap-farm "
                                 f"label writes it; or copy the assembly's JSON file there)")
            a = self._assemblies[name] = load_assembly(f)
        if a.geometry_hash != geometry_hash:
            raise InputError(f"{self.root}: assembly {name!r}: the geometry of "
                             f"_assemblies/{name}.json differs from the labelled rows'")
        return a

    def descriptors(self, names: tuple[str, ...], assembly, geometry_hash, moving, fixed,
                    direction) -> np.ndarray:
        """float32 [N, len(names)] for rows given as parallel sequences (direction [N, 2])."""
        from rap.model.data.descriptors import DescriptorContext, columns
        from rap.operation import Operation

        cols = columns(names)
        out = np.empty((len(assembly), len(names)), dtype=np.float32)
        for i in range(len(assembly)):
            name = assembly[i]
            ctx = self._contexts.get(name)
            if ctx is None:
                ctx = self._contexts[name] = DescriptorContext(
                    self.assembly(name, geometry_hash[i]))
            elif ctx.assembly.geometry_hash != geometry_hash[i]:
                self.assembly(name, geometry_hash[i])  # raises: the rows disagree
            op = Operation(frozenset(moving[i].split(",")), frozenset(fixed[i].split(",")),
                           (float(direction[i][0]), float(direction[i][1])))
            try:
                out[i] = ctx.descriptors(op)[cols]
            except ValueError as e:
                raise InputError(f"{self.root}: assembly {name!r}: row {i}: {e}") from None
        return out


def descriptor_columns(store, names: tuple[str, ...],
                       progress: Callable[[int, int], None] | None = None) -> np.ndarray:
    """float32 [N, len(names)]: the descriptors ``names`` of every row of a ``RowStore``, made
    once and cached by the rows' keys (``progress(done, total)`` every ``PROGRESS_ROWS`` rows
    computed). Raises ``InputError`` as ``extra_channels`` does."""
    from rap.model.data.descriptors import DESCRIPTORS, VERSION, columns

    def compute() -> np.ndarray:
        geometry = DatasetGeometry(store.root)
        out = np.empty((len(store), len(DESCRIPTORS)), dtype=np.float32)
        for s in range(0, len(store), PROGRESS_ROWS):
            e = min(s + PROGRESS_ROWS, len(store))
            out[s:e] = geometry.descriptors(DESCRIPTORS, store.assembly[s:e],
                                            store.geometry_hash[s:e], store.moving[s:e],
                                            store.fixed[s:e], store.direction[s:e])
            if progress is not None:
                progress(e, len(store))
        return out

    arr = _cached(f"descriptors-v{VERSION}:{','.join(DESCRIPTORS)}", store,
                  (len(store), len(DESCRIPTORS)), compute)
    return np.ascontiguousarray(arr[:, columns(names)])
