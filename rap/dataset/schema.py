"""The dataset's schema: its Arrow columns, version, image layout and metadata record."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Iterable

import numpy as np
import pyarrow as pa

from rap import __version__

SCHEMA_VERSION = 2
IMAGE_SIZE = 64
IMAGE_BYTES = 2 * IMAGE_SIZE * IMAGE_SIZE
METADATA_FILE = "_rapfarm.json"
GEOMETRY_DIR = "_assemblies"  # the labelled assemblies' geometry (write_geometry)
LOCK_FILE = "_rapfarm.lock"  # held by the one writer (lock_dataset)
QUARANTINE_DIR = "_quarantine"  # corrupt shards moved aside (quarantine)

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


def decode_images(column: pa.Array | pa.ChunkedArray) -> np.ndarray:
    """Fixed-size-binary image column -> uint8 array [N, 2, 64, 64] without per-row Python work."""
    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    buf = column.buffers()[1]
    start = column.offset * IMAGE_BYTES
    flat = np.frombuffer(buf, dtype=np.uint8, count=len(column) * IMAGE_BYTES, offset=start)
    return flat.reshape(len(column), 2, IMAGE_SIZE, IMAGE_SIZE)

