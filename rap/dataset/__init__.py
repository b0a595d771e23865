"""The labelled-operation dataset: a versioned Arrow schema and atomic Parquet shards.

Layout of a dataset directory ``DIR``::

    DIR/_rapfarm.json                       dataset metadata (schema version, command, root seed,
                                            simulator parameters, code version)
    DIR/NAME/part-<uuid>.parquet            shards, one directory per assembly (the ``assembly``
                                            column is in every shard, so each file stands alone)
    DIR/_assemblies/NAME.json               each labelled assembly's geometry (``write_geometry``)
    DIR/_rapfarm.lock                       while a writer runs: its pid, host, start and command
                                            (``lock_dataset``)
    DIR/_quarantine/NAME/part-<uuid>.parquet   corrupt shards moved aside (``quarantine``)

Shards are written to a temporary name in the same directory, fsync'ed and renamed into place, so
a reader (or a resumed run) never sees a half-written file; a write that fails (a full disk, a
read-only file system) raises ``StorageError`` naming the path and leaves no temporary file.
Readers: ``pyarrow.dataset``, ``pandas.read_parquet(DIR)``, ``ray.data.read_parquet(DIR)``; they
skip the ``_`` and ``.`` paths, so the lock, the geometry and the quarantine are not data.

One writer per dataset: ``lock_dataset`` takes an advisory ``fcntl.flock`` on ``DIR/_rapfarm.lock``
and holds it until ``release()`` or the end of the process (the kernel drops it, so a killed
writer never blocks the next run); a second writer is refused at once with ``DatasetBusyError``
naming the holder. On file systems without ``flock`` the file is created exclusively instead, and
a file left by a dead process of this host is taken over.

Faults in what is read are one line: a shard whose footer or pages do not read raises
``CorruptShardError`` naming the file (``shard_problem``, ``corrupt_shards`` and ``quarantine``
find and move them aside); keys stored more than once (two writers before the lock existed) are
counted by ``duplicate_keys``, and ``read_table``/``iter_batches``/``count_rows`` with
``unique=True`` keep each key's first row, by shard path and then row order.

No ray, no torch here.

Modules: ``schema`` (the columns, version and metadata record), ``storage`` (atomic writes, the
metadata), ``lock`` (one writer), ``reading`` (shards, corrupt shards, duplicate keys, reads).
This package's names below are its public interface.
"""

import importlib

from rap.dataset.lock import DatasetBusyError, DatasetLock, lock_dataset
from rap.dataset.schema import (GEOMETRY_DIR, IMAGE_BYTES, IMAGE_SIZE, LOCK_FILE, METADATA_FILE,
                                QUARANTINE_DIR, SCHEMA, SCHEMA_VERSION, DatasetMeta, decode_images,
                                rows_to_table)
from rap.dataset.storage import (clean_partial_files, read_meta, write_geometry, write_meta,
                                 write_shard)
from rap.files import committed_file_mode

__all__ = [
    "SCHEMA_VERSION",
    "IMAGE_SIZE",
    "IMAGE_BYTES",
    "SCHEMA",
    "METADATA_FILE",
    "GEOMETRY_DIR",
    "LOCK_FILE",
    "QUARANTINE_DIR",
    "DatasetBusyError",
    "CorruptShardError",
    "DatasetLock",
    "lock_dataset",
    "shard_files",
    "shard_problem",
    "corrupt_shards",
    "quarantine",
    "Duplicates",
    "duplicate_keys",
    "read_table",
    "count_rows",
    "iter_shard_batches",
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

#: the names of ``reading``, imported at their first use (PEP 562): reading needs pyarrow.dataset,
#: which imports pandas (about 0.7 s), and a process that only writes rows (a simulation actor,
#: ``rap.labelling.rows``) never reads a dataset
_READING = {"CorruptShardError", "Duplicates", "corrupt_shards", "count_rows", "duplicate_keys",
            "existing_keys", "iter_batches", "iter_shard_batches", "open_dataset", "quarantine",
            "read_table", "shard_files", "shard_problem"}


def __getattr__(name: str):
    if name in _READING:
        value = getattr(importlib.import_module("rap.dataset.reading"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'rap.dataset' has no attribute {name!r}")
