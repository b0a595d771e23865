"""Extra input channels a network may be trained on, rendered again from the dataset's geometry.

A dataset stores the start/goal pair (``view="pair"``). The ``"pair+crop"`` view adds the close-up
of the mating region (``rap.render.images.render_crop``), which the dataset does not store: it is
rendered from each row's assembly, found as ``DATASET/_assemblies/NAME.json`` (the corpus ships
them), else among the packaged reference assemblies, and checked against the row's geometry hash.
The rendered channels are cached under ``$RAP_CACHE_DIR`` (default ``~/.cache/rap-farm/views``) by
the dataset's content (the keys of its rows), so they are rendered once per dataset version.

Cost: one ``render_crop`` per row (about 1 ms), once; memory 8 KiB per row and extra view.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Callable

import numpy as np

from rap.errors import InputError

__all__ = ["extra_channels", "assembly_file", "cache_dir", "PROGRESS_ROWS"]

PROGRESS_ROWS = 1024


def cache_dir() -> Path:
    base = os.environ.get("RAP_CACHE_DIR")
    return Path(base) if base else Path.home() / ".cache" / "rap-farm" / "views"


def assembly_file(root: str | Path, name: str) -> Path | None:
    """The JSON file of assembly ``name`` of the dataset at ``root`` (see the module docstring)."""
    p = Path(root) / "_assemblies" / f"{name}.json"
    if p.is_file():
        return p
    import rap

    p = Path(rap.__file__).resolve().parent / "data" / "assemblies" / f"{name}.json"
    return p if p.is_file() else None


def extra_channels(store, view: str,
                   progress: Callable[[int, int], None] | None = None) -> np.ndarray | None:
    """uint8 [N, k, 64, 64]: the channels of ``view`` beyond the stored pair, for every row of a
    ``rap.model.data.RowStore`` (None for ``"pair"``). Raises ``InputError`` when a row's assembly
    cannot be found or its geometry differs. ``progress(done, total)`` is called every
    ``PROGRESS_ROWS`` rows rendered (not when the cache has them; about 1 ms a row)."""
    if view == "pair":
        return None
    if view != "pair+crop":
        raise InputError(f"view {view!r}: pair or pair+crop")
    from rap.io import load_assembly
    from rap.operation import Operation
    from rap.render.images import render_crop

    h = hashlib.sha256(view.encode())
    for k in store.keys.tolist():
        h.update(k.encode())
    path = cache_dir() / f"{h.hexdigest()[:24]}.npy"
    if path.is_file():
        arr = np.load(path, mmap_mode=None)
        if arr.shape[0] == len(store):
            return arr
    assemblies = {}
    out = np.empty((len(store), 2, 64, 64), dtype=np.uint8)
    for i in range(len(store)):
        name = store.assembly[i]
        a = assemblies.get(name)
        if a is None:
            f = assembly_file(store.root, name)
            if f is None:
                raise InputError(f"{store.root}: no geometry for assembly {name!r} (expected "
                                 f"_assemblies/{name}.json) to render the {view} view")
            a = assemblies[name] = load_assembly(f)
        if a.geometry_hash != store.geometry_hash[i]:
            raise InputError(f"{store.root}: assembly {name!r}: the geometry of "
                             f"_assemblies/{name}.json differs from the labelled rows'")
        op = Operation(frozenset(store.moving[i].split(",")), frozenset(store.fixed[i].split(",")),
                       (float(store.direction[i, 0]), float(store.direction[i, 1])))
        out[i] = render_crop(a, op)
        if progress is not None and ((i + 1) % PROGRESS_ROWS == 0 or i + 1 == len(store)):
            progress(i + 1, len(store))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npy")
    np.save(tmp, out)
    tmp.replace(path)
    return out
