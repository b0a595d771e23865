"""Writing a dataset without ever leaving a partial file: atomic shards, metadata and geometry.

Every file is written to a hidden temporary name beside its target, fsync'ed and renamed into
place; a failed write raises ``StorageError`` naming the path (``storage_error``) and leaves no
temporary file. ``read_meta`` reads the metadata back, refusing anything else in one line.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import tempfile
import uuid
from pathlib import Path
from typing import Iterable, Iterator

import pyarrow as pa
import pyarrow.parquet as pq

from rap.errors import InputError, StorageError, one_line
from rap.files import committed_file_mode

from rap.dataset.schema import GEOMETRY_DIR, METADATA_FILE, DatasetMeta

_TMP_PREFIX = ".tmp-"
COMPRESSION_LEVEL = 3  # zstd: ~16 us a row with images; level 12 writes ~16% smaller shards at ~10x the CPU


def fsync_dir(path: Path) -> None:
    """Make a rename in directory ``path`` durable (fsync the directory; best effort)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def storage_error(path: Path, exc: OSError) -> StorageError:
    """One line saying what failed and where: ``disk full`` for ENOSPC/EDQUOT, else the reason."""
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        why = "disk full" + (" (quota exceeded)" if exc.errno == errno.EDQUOT else "")
    else:
        why = exc.strerror or str(exc) or type(exc).__name__
    return StorageError(f"{path}: cannot write: {why}; committed files are kept, no partial file "
                        f"is left")


@contextlib.contextmanager
def _temporary(target: Path, suffix: str = "") -> Iterator[tuple[int, str]]:
    """A hidden temporary file beside ``target`` (mode: ``committed_file_mode``), yielded as (fd,
    path) and unlinked unless the body renamed it away; an ``OSError`` in the body, ``mkdir``
    included, becomes a ``StorageError`` naming ``target``."""
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=suffix, dir=target.parent)
        try:
            os.fchmod(fd, committed_file_mode())
        except OSError:
            os.close(fd)
            raise
        yield fd, tmp
    except OSError as exc:
        raise storage_error(target, exc) from None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):  # FileNotFoundError: renamed into place
                os.unlink(tmp)


def write_shard(root: str | Path, table: pa.Table) -> list[Path]:
    """Atomically write ``table`` as one Parquet shard per assembly under ``root``.

    Each shard goes to a hidden temporary file in its partition directory, is fsync'ed and then
    renamed into place: an interrupted write leaves at most a hidden ``.tmp-*`` file, never a
    visible partial shard, and a failed one (``StorageError``: disk full, read-only) none.
    Returns the paths written.
    """
    root = Path(root)
    written = []
    for name in sorted(set(table.column("assembly").to_pylist())):
        part = table.filter(pa.compute.equal(table.column("assembly"), name))
        d = root / name
        final = d / f"part-{uuid.uuid4().hex}.parquet"
        with _temporary(final, ".parquet") as (fd, tmp):
            with os.fdopen(fd, "wb") as fh:
                pq.write_table(part, fh, compression="zstd", compression_level=COMPRESSION_LEVEL)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, final)
            fsync_dir(d)
        written.append(final)
    return written


def clean_partial_files(root: str | Path) -> int:
    """Remove leftover hidden temporary files of an interrupted writer (shards, metadata,
    geometry: ``DIR/.tmp-*``, ``DIR/*/.tmp-*``). Returns how many. Call it with the dataset
    locked (``lock_dataset``): another writer's temporary files are in flight."""
    n = 0
    root = Path(root)
    for p in [*root.glob(f"{_TMP_PREFIX}*"), *root.glob(f"*/{_TMP_PREFIX}*")]:
        p.unlink(missing_ok=True)
        n += 1
    return n


def _write_atomic(path: Path, text: str) -> None:
    with _temporary(path) as (fd, tmp):
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)


def write_meta(root: str | Path, meta: DatasetMeta) -> None:
    """Atomically write the dataset metadata file."""
    _write_atomic(Path(root) / METADATA_FILE, meta.to_json())


def write_geometry(root: str | Path, assemblies: Iterable) -> int:
    """Keep each assembly's geometry beside the rows, as ``GEOMETRY_DIR/NAME.json`` (canonical
    JSON, atomically; readers skip ``_`` paths), so that views and descriptors can be made again
    from the dataset alone (``rap.model.data.views``). A file that holds the same geometry is left as
    it is. Returns how many files were written. Cost: one small file per assembly."""
    from rap.io import load_assembly
    from rap.assembly import AssemblyError, assembly_to_json

    n = 0
    for a in assemblies:
        path = Path(root) / GEOMETRY_DIR / f"{a.name}.json"
        if path.is_file():
            try:
                if load_assembly(path, validate=False).geometry_hash == a.geometry_hash:
                    continue
            except AssemblyError:
                pass  # unreadable: written again
        _write_atomic(path, json.dumps(assembly_to_json(a), separators=(",", ":")) + "\n")
        n += 1
    return n


_META_FIELDS = {"schema_version": int, "root_seed": int, "params": dict, "command": str,
                "code_version": str}
_META_MAX_BYTES = 1 << 20


def read_meta(root: str | Path) -> DatasetMeta | None:
    """The dataset's metadata, or None when ``root`` holds no rap-farm dataset yet. A file that is
    not the metadata (unreadable, not JSON, nested too deeply, fields missing or of other types,
    over 1 MiB) raises ``InputError`` with one line."""
    p = Path(root) / METADATA_FILE
    if not p.exists():
        return None

    def bad(why: str) -> InputError:
        return InputError(f"{p}: not a rap-farm dataset metadata file ({why})")

    try:
        if p.stat().st_size > _META_MAX_BYTES:
            raise bad(f"over {_META_MAX_BYTES:,} bytes")
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:  # ValueError: JSON, UTF-8
        raise bad(one_line(exc)) from None
    if not isinstance(d, dict):
        raise bad(f"a JSON {type(d).__name__}, not an object")
    missing = [k for k in _META_FIELDS if k not in d and k != "code_version"]
    if missing or set(d) - set(_META_FIELDS):
        why = (f"missing {', '.join(missing)}" if missing
               else f"unknown field {sorted(set(d) - set(_META_FIELDS))[0]!r}")
        raise bad(why)
    for k, t in _META_FIELDS.items():
        if k in d and (not isinstance(d[k], t) or isinstance(d[k], bool)):
            raise bad(f"{k} is a JSON {type(d[k]).__name__}, not {t.__name__}")
    return DatasetMeta(**d)

