"""The labelled-operation dataset: a versioned Arrow schema and atomic Parquet shards.

Layout of a dataset directory ``DIR``::

    DIR/_rapfarm.json                       dataset metadata (schema version, command, root seed,
                                            simulator parameters, code version)
    DIR/NAME/part-<uuid>.parquet            shards, one directory per assembly (the ``assembly``
                                            column is in every shard, so each file stands alone)
    DIR/_assemblies/NAME.json               each labelled assembly's geometry (``write_geometry``)

Shards are written to a temporary name in the same directory, fsync'ed and renamed into place, so
a reader (or a resumed run) never sees a half-written file. Readers: ``pyarrow.dataset``,
``pandas.read_parquet(DIR)``, ``ray.data.read_parquet(DIR)``.

No ray, no torch here.
"""

from __future__ import annotations

import json
import os
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pyarrow as pa
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from rap import __version__
from rap.errors import InputError
from rap.files import committed_file_mode

__all__ = [
    "SCHEMA_VERSION",
    "IMAGE_SIZE",
    "IMAGE_BYTES",
    "SCHEMA",
    "METADATA_FILE",
    "GEOMETRY_DIR",
    "write_geometry",
    "DatasetMeta",
    "rows_to_table",
    "write_shard",
    "read_meta",
    "write_meta",
    "open_dataset",
    "existing_keys",
    "decode_images",
    "iter_batches",
    "clean_partial_files",
    "committed_file_mode",
]

SCHEMA_VERSION = 2
IMAGE_SIZE = 64
IMAGE_BYTES = 2 * IMAGE_SIZE * IMAGE_SIZE
METADATA_FILE = "_rapfarm.json"
GEOMETRY_DIR = "_assemblies"  # the labelled assemblies' geometry (write_geometry)
_TMP_PREFIX = ".tmp-"
COMPRESSION_LEVEL = 12  # zstd: ~25% smaller shards than the default level at ~0.1 ms per row

SCHEMA = pa.schema(
    [
        pa.field("key", pa.string(), nullable=False),
        pa.field("assembly", pa.string(), nullable=False),
        pa.field("geometry_hash", pa.string(), nullable=False),
        pa.field("subassembly", pa.string(), nullable=False),
        pa.field("moving", pa.string(), nullable=False),
        pa.field("fixed", pa.string(), nullable=False),
        pa.field("direction_x", pa.float64(), nullable=False),
        pa.field("direction_y", pa.float64(), nullable=False),
        pa.field("score", pa.float64(), nullable=False),
        pa.field("successes", pa.int32(), nullable=False),
        pa.field("trials", pa.int32(), nullable=False),
        pa.field("image", pa.binary(IMAGE_BYTES), nullable=False),
        pa.field("seed", pa.int64(), nullable=False),
        pa.field("params", pa.string(), nullable=False),
        pa.field("code_version", pa.string(), nullable=False),
        pa.field("node", pa.string(), nullable=False),
        # schema 2: where the assembly comes from (rap.assembly.Assembly.family) and which of its
        # partition's directions the operation takes (0 the middle of the range). Nullable so that
        # schema-1 shards still read (as nulls).
        pa.field("family", pa.string(), nullable=True),
        pa.field("direction_index", pa.int32(), nullable=True),
    ],
    metadata={b"rapfarm.schema_version": str(SCHEMA_VERSION).encode()},
)



@dataclass(frozen=True)
class DatasetMeta:
    """Dataset-level metadata stored in ``_rapfarm.json``."""

    schema_version: int
    root_seed: int
    params: dict
    command: str
    code_version: str = __version__

    def to_json(self) -> str:
        return json.dumps(self.__dict__, indent=2, sort_keys=True)


def rows_to_table(rows: Iterable[dict]) -> pa.Table:
    """A table in ``SCHEMA`` from dicts; ``image`` may be bytes or a uint8 array [2, 64, 64]."""
    rows = list(rows)
    cols = {}
    for f in SCHEMA:
        vals = [r[f.name] if f.name in r or not f.nullable else None for r in rows]
        if f.name == "image":
            vals = [v if isinstance(v, (bytes, bytearray)) else np.ascontiguousarray(v, np.uint8).tobytes()
                    for v in vals]
        cols[f.name] = pa.array(vals, type=f.type)
    return pa.Table.from_pydict(cols, schema=SCHEMA)


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_shard(root: str | Path, table: pa.Table) -> list[Path]:
    """Atomically write ``table`` as one Parquet shard per assembly under ``root``.

    Each shard goes to a hidden temporary file in its partition directory, is fsync'ed and then
    renamed into place: an interrupted write leaves at most a hidden ``.tmp-*`` file, never a
    visible partial shard. Returns the paths written.
    """
    root = Path(root)
    written = []
    for name in sorted(set(table.column("assembly").to_pylist())):
        part = table.filter(pa.compute.equal(table.column("assembly"), name))
        d = root / name
        d.mkdir(parents=True, exist_ok=True)
        final = d / f"part-{uuid.uuid4().hex}.parquet"
        fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=".parquet", dir=d)
        try:
            os.fchmod(fd, committed_file_mode())
            with os.fdopen(fd, "wb") as fh:
                pq.write_table(part, fh, compression="zstd", compression_level=COMPRESSION_LEVEL)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, final)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        _fsync_dir(d)
        written.append(final)
    return written


def clean_partial_files(root: str | Path) -> int:
    """Remove leftover hidden temporary shards from an interrupted writer. Returns how many."""
    n = 0
    for p in Path(root).glob(f"*/{_TMP_PREFIX}*"):
        p.unlink(missing_ok=True)
        n += 1
    return n


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, dir=path.parent)
    os.fchmod(fd, committed_file_mode())
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
    from the dataset alone (``rap.model.views``). A file that holds the same geometry is left as
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


def read_meta(root: str | Path) -> DatasetMeta | None:
    """The dataset's metadata, or None when ``root`` holds no rap-farm dataset yet."""
    p = Path(root) / METADATA_FILE
    if not p.exists():
        return None
    try:
        d = json.loads(p.read_text())
        return DatasetMeta(**d)
    except (json.JSONDecodeError, TypeError) as exc:
        raise InputError(f"{p}: not a rap-farm dataset metadata file ({exc})") from None


def open_dataset(root: str | Path) -> pads.Dataset:
    """A ``pyarrow.dataset`` over the committed shards (hidden temporary files are ignored)."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: no such dataset directory")
    files = sorted(str(p) for p in root.glob("*/part-*.parquet"))
    if not files:
        raise InputError(f"{root}: dataset has no shards")
    return pads.dataset(files, schema=SCHEMA, format="parquet")


def existing_keys(root: str | Path) -> set[str]:
    """Content keys of every committed row (empty when there is no dataset yet)."""
    root = Path(root)
    if not any(root.glob("*/part-*.parquet")):
        return set()
    return set(open_dataset(root).to_table(columns=["key"]).column("key").to_pylist())


def decode_images(column: pa.Array | pa.ChunkedArray) -> np.ndarray:
    """Fixed-size-binary image column -> uint8 array [N, 2, 64, 64] without per-row Python work."""
    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    buf = column.buffers()[1]
    start = column.offset * IMAGE_BYTES
    flat = np.frombuffer(buf, dtype=np.uint8, count=len(column) * IMAGE_BYTES, offset=start)
    return flat.reshape(len(column), 2, IMAGE_SIZE, IMAGE_SIZE)


def iter_batches(root: str | Path, columns: list[str] | None = None, batch_size: int = 256,
                 filter=None) -> Iterator[pa.RecordBatch]:
    """Stream record batches from the dataset without loading it whole."""
    ds = open_dataset(root)
    yield from ds.to_batches(columns=columns, batch_size=batch_size, filter=filter)
