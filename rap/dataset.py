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
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import socket
import tempfile
import time
import uuid
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from rap import __version__
from rap.errors import InputError, StorageError, WorkFailedError
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

SCHEMA_VERSION = 2
IMAGE_SIZE = 64
IMAGE_BYTES = 2 * IMAGE_SIZE * IMAGE_SIZE
METADATA_FILE = "_rapfarm.json"
GEOMETRY_DIR = "_assemblies"  # the labelled assemblies' geometry (write_geometry)
LOCK_FILE = "_rapfarm.lock"  # held by the one writer (lock_dataset)
QUARANTINE_DIR = "_quarantine"  # corrupt shards moved aside (quarantine)
_TMP_PREFIX = ".tmp-"
_SHARD_GLOB = "*/part-*.parquet"
COMPRESSION_LEVEL = 3  # zstd: ~16 us a row with images; level 12 writes ~16% smaller shards at ~10x the CPU

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


def _storage_error(path: Path, exc: OSError) -> StorageError:
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
        raise _storage_error(target, exc) from None
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
            _fsync_dir(d)
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


_META_FIELDS = {"schema_version": int, "root_seed": int, "params": dict, "command": str,
                "code_version": str}
_META_MAX_BYTES = 1 << 20


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, RecursionError):
        return "nested too deeply"
    text = str(exc).strip().splitlines()
    line = text[0] if text else type(exc).__name__
    return line if len(line) <= 200 else line[:199] + "…"


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
        raise bad(_one_line(exc)) from None
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


# -- one writer per dataset ---------------------------------------------------------------------
class DatasetBusyError(WorkFailedError):
    """Another process is writing the dataset: one line naming it (pid, host, start, command).
    Exit status 3 (run again once it has finished); nothing is written."""


_NO_FLOCK = {errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.ENOSYS, errno.EINVAL}


@dataclass(eq=False)
class DatasetLock:
    """The advisory lock of one writer on a dataset directory (``lock_dataset``): ``release()``
    (or leaving a ``with`` block, or the object being collected, or the process ending) unlinks
    the lock file and releases it, and removes the directories ``lock_dataset`` created when they
    are still empty."""

    root: Path
    path: Path
    owner: dict
    _finalizer: weakref.finalize | None = field(default=None, repr=False)

    @property
    def held(self) -> bool:
        return self._finalizer is not None and self._finalizer.alive

    def release(self) -> None:
        if self._finalizer is not None:
            self._finalizer()

    def __enter__(self) -> "DatasetLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def _describe_owner(text: str) -> str:
    """``pid 123 on HOST, started 2026-01-01T00:00:00+0000: rap-farm label ...`` (a lock file's)."""
    try:
        d = json.loads(text)
        head = f"pid {int(d['pid'])} on {d['host']}"
    except (ValueError, TypeError, KeyError, RecursionError):
        return "a process that has not written its pid and host yet"
    started = f", started {d['started']}" if d.get("started") else ""
    command = " ".join(str(d.get("command") or "").split())
    if len(command) > 120:
        command = command[:119] + "…"
    return head + started + (f": {command}" if command else "")


def _busy(root: Path, text: str) -> DatasetBusyError:
    return DatasetBusyError(f"{root}: another run is writing this dataset "
                            f"({_describe_owner(text)}); nothing was done: run again once it has "
                            f"finished, or choose another --out")


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")[:4096]
    except OSError:
        return ""


def _pid_alive(pid: int) -> bool:
    if pid <= 0:  # not a process (0, -N: process groups)
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _flock(path: Path, text: str, root: Path) -> int | None:
    """The fd of ``path`` with an exclusive ``flock`` held and ``text`` written in it; None when
    the file system has no ``flock``. Raises ``DatasetBusyError`` when another process holds it."""
    import fcntl

    for _ in range(16):  # a holder that releases unlinks the file we may have opened: open again
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, committed_file_mode())
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise _busy(root, _read_text(path)) from None
        except OSError as exc:
            os.close(fd)
            if exc.errno in _NO_FLOCK:
                return None
            raise
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            _write_owner(fd, path, text)
            return fd
        os.close(fd)
    raise _busy(root, _read_text(path))


def _write_owner(fd: int, path: Path, text: str) -> None:
    """Write the holder's details into the lock file ``path`` open at ``fd``; on failure (a full
    disk) remove and close it, which releases the lock, and raise."""
    try:
        os.ftruncate(fd, 0)
        os.write(fd, text.encode())
    except OSError:
        _unlock(fd, path, [])
        raise


def _exclusive(path: Path, text: str, root: Path) -> int:
    """Without ``flock``: create ``path`` exclusively; a file left by a dead process of this host
    (pid no longer alive) is stale and taken over. Raises ``DatasetBusyError`` otherwise."""
    for _ in range(2):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC,
                         committed_file_mode())
        except FileExistsError:
            held = _read_text(path)
            try:
                d = json.loads(held)
                stale = d["host"] == socket.gethostname() and not _pid_alive(int(d["pid"]))
            except (ValueError, TypeError, KeyError, RecursionError):
                stale = False
            if not stale:
                raise _busy(root, held) from None
            path.unlink(missing_ok=True)
            continue
        _write_owner(fd, path, text)
        return fd
    raise _busy(root, _read_text(path))


def _unlock(fd: int, path: Path, created: list[Path]) -> None:
    try:
        if os.path.samestat(os.fstat(fd), os.stat(path)):
            os.unlink(path)
    except OSError:
        pass
    finally:
        os.close(fd)  # releases the flock
    _remove_empty(created)


def lock_dataset(root: str | Path, command: str = "") -> DatasetLock:
    """Take the one-writer lock of the dataset at ``root`` (created, with its parents, when
    missing; removed again on release while still empty). Writes ``{"pid", "host", "started",
    "command"}`` into ``root/_rapfarm.lock``. Raises ``DatasetBusyError`` (one line naming the
    holder) when another process, or another lock in this one, holds it; ``StorageError`` when
    the directory or the file cannot be made. Cost: a few system calls."""
    root = Path(root)
    created: list[Path] = []
    d = root
    while not d.exists() and d.parent != d:
        created.append(d)
        d = d.parent
    created.reverse()  # the topmost first
    path = root / LOCK_FILE
    owner = {"pid": os.getpid(), "host": socket.gethostname(),
             "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": command}
    text = json.dumps(owner) + "\n"
    try:
        for c in created:
            c.mkdir()
        fd = _flock(path, text, root)
        if fd is None:
            fd = _exclusive(path, text, root)
    except OSError as exc:
        _remove_empty(created)
        raise _storage_error(path, exc) from None
    except BaseException:
        _remove_empty(created)
        raise
    lock = DatasetLock(root, path, owner)
    lock._finalizer = weakref.finalize(lock, _unlock, fd, path, created)
    return lock


def _remove_empty(created: list[Path]) -> None:
    """Remove the directories ``lock_dataset`` made (topmost first in ``created``), the deepest
    first, while they are empty."""
    for d in reversed(created):
        try:
            d.rmdir()
        except OSError:
            break


# -- reading: shards, corrupt shards, duplicate keys ----------------------------------------------
class CorruptShardError(InputError):
    """A shard that does not read (truncated, garbage, another schema): one line naming it.
    Exit status 2."""

    def __init__(self, path: str | Path, reason: str, root: str | Path | None = None):
        self.path, self.reason = Path(path), reason
        hint = ""
        if root is not None:
            import shlex

            hint = (f"; `rap-farm check {shlex.quote(str(root))} --quarantine` moves it aside and "
                    f"a rerun of `rap-farm label` refills its rows")
        super().__init__(f"{path}: corrupt shard ({reason}){hint}")


def shard_files(root: str | Path) -> list[Path]:
    """The committed shards ``root/NAME/part-*.parquet``, sorted by path; directories named
    ``_*`` or ``.*`` are not data (readers skip them) and are left out."""
    return sorted((p for p in Path(root).glob(_SHARD_GLOB)
                   if not p.parent.name.startswith(("_", "."))), key=str)


def _reason(exc: BaseException) -> str:
    return re.sub(r"^Could not open Parquet input source '[^']*': ", "", _one_line(exc))


def _schema_problem(schema: pa.Schema) -> str | None:
    for f in SCHEMA:
        i = schema.get_field_index(f.name)
        if i < 0:
            if not f.nullable:
                return f"no column {f.name!r}"
        elif schema.field(i).type != f.type:
            return f"column {f.name!r} is {schema.field(i).type}, not {f.type}"
    return None


def _footer_problem(path: Path) -> str | None:
    try:
        schema = pq.read_schema(path)
    except (pa.ArrowException, OSError, ValueError) as exc:
        return _reason(exc)
    return _schema_problem(schema)


def shard_problem(path: str | Path) -> str | None:
    """Why the shard at ``path`` does not read (its footer, its schema against ``SCHEMA``, every
    page of every column), or None when it reads whole. Cost: one read of the file, a batch at a
    time."""
    path = Path(path)
    why = _footer_problem(path)
    if why is not None:
        return why
    try:
        with pq.ParquetFile(path) as pf:
            for _ in pf.iter_batches(batch_size=1024):
                pass
    except (pa.ArrowException, OSError, ValueError) as exc:
        return _reason(exc)
    return None


def corrupt_shards(root: str | Path) -> list[tuple[Path, str]]:
    """Every shard of the dataset that does not read, with the reason (``shard_problem``)."""
    return [(p, why) for p in shard_files(root) if (why := shard_problem(p)) is not None]


def quarantine(root: str | Path, paths: Iterable[str | Path]) -> list[Path]:
    """Move shards to ``root/_quarantine/NAME/`` (readers skip it; a rerun of ``label`` refills
    their rows); a name already taken there gets a number. Returns the new paths. Take the
    dataset's lock first (``lock_dataset``). Raises ``StorageError``."""
    root = Path(root)
    moved = []
    for p in map(Path, paths):
        d = root / QUARANTINE_DIR / p.parent.name
        dest = d / p.name
        try:
            d.mkdir(parents=True, exist_ok=True)
            i = 1
            while dest.exists():
                dest = d / f"{p.stem}.{i}{p.suffix}"
                i += 1
            os.replace(p, dest)
        except OSError as exc:
            raise _storage_error(dest, exc) from None
        _fsync_dir(d)
        _fsync_dir(p.parent)
        moved.append(dest)
    return moved


_FOOTERS_OK: set[tuple[str, int, int]] = set()  # (path, size, mtime_ns) of shards whose footer read


def _stat_key(p: Path) -> tuple[str, int, int]:
    st = p.stat()
    return str(p), st.st_size, st.st_mtime_ns


def _check_footers(root: Path, files: list[Path]) -> None:
    if len(_FOOTERS_OK) > 1_000_000:
        _FOOTERS_OK.clear()
    for p in files:
        k = _stat_key(p)
        if k not in _FOOTERS_OK:
            why = _footer_problem(p)
            if why is not None:
                raise CorruptShardError(p, why, root)
            _FOOTERS_OK.add(k)


@contextlib.contextmanager
def _reading(root: Path) -> Iterator[None]:
    """Turns a read error of a shard (a corrupt page past a sound footer) into
    ``CorruptShardError`` naming it: the file named in pyarrow's message, else the first shard
    that ``shard_problem`` finds; any other error propagates as it is."""
    try:
        yield
    except (pa.ArrowException, OSError) as exc:
        files = shard_files(root)
        named = re.search(r"'([^']+\.parquet)'", str(exc))
        if named and Path(named[1]) in set(files):
            raise CorruptShardError(named[1], _reason(exc), root) from None
        for p in files:
            why = shard_problem(p)
            if why is not None:
                raise CorruptShardError(p, why, root) from None
        raise


def open_dataset(root: str | Path) -> pads.Dataset:
    """A ``pyarrow.dataset`` over the committed shards (``shard_files``; temporary files, the
    lock and the quarantine are ignored). Each shard's footer is read once per process (and
    again when the file changes): a shard whose footer does not read raises
    ``CorruptShardError``."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: no such dataset directory")
    files = shard_files(root)
    if not files:
        raise InputError(f"{root}: dataset has no shards")
    _check_footers(root, files)
    return pads.dataset([str(p) for p in files], schema=SCHEMA, format="parquet")


def _shard_id(path: str | Path) -> str:
    """``NAME/part-<uuid>.parquet``: a shard's path inside its dataset."""
    p = Path(path)
    return f"{p.parent.name}/{p.name}"


@dataclass(eq=False)
class Duplicates:
    """Keys stored more than once in a dataset: ``first`` maps each to the shard (``NAME/part-…``)
    whose row is kept (the first by shard path, then by row); ``rows`` counts the rows beyond
    each key's first. Falsy when there are none."""

    root: str
    rows: int = 0
    first: dict[str, str] = field(default_factory=dict)
    _values: pa.Array | None = field(default=None, repr=False)

    def __bool__(self) -> bool:
        return self.rows > 0

    @property
    def values(self) -> pa.Array:
        if self._values is None:
            self._values = pa.array(sorted(self.first), pa.string())
        return self._values

    def describe(self) -> str:
        return (f"{self.root}: {self.rows} duplicate rows ({len(self.first)} keys stored more than "
                f"once); each key's first row (by shard path, then row) is used")

    def keep(self, keys: pa.Array | pa.ChunkedArray, shards, kept: set[str]) -> np.ndarray | None:
        """Which of these rows to keep (None: all): a row of a duplicated key is kept when it is
        in the key's first shard and that shard's first row of it (``kept`` records the keys kept
        so far; rows come in shard order). ``shards``: one shard path for every row, or a column
        of them."""
        if isinstance(keys, pa.ChunkedArray):
            keys = keys.combine_chunks()
        hit = np.flatnonzero(pc.is_in(keys, value_set=self.values).to_numpy(zero_copy_only=False))
        if not len(hit):
            return None
        mask = np.ones(len(keys), dtype=bool)
        idx = pa.array(hit)
        ks = keys.take(idx).to_pylist()
        ss = ([_shard_id(shards)] * len(hit) if isinstance(shards, (str, Path))
              else [_shard_id(s) for s in pc.take(shards, idx).to_pylist()])
        for j, k, s in zip(hit, ks, ss):
            if s == self.first[k] and k not in kept:
                kept.add(k)
            else:
                mask[j] = False
        return mask


_DUPLICATES: dict[str, tuple[tuple, Duplicates]] = {}  # root -> (shards' stat keys, result)


def _scan_keys(root: Path, files: list[Path]) -> pa.ChunkedArray:
    """Every row's key (one read of the key column), recording the dataset's ``Duplicates``."""
    ds = open_dataset(root)
    with _reading(root):
        t = ds.scanner(columns=["key", "__filename"]).to_table()
    keys = t.column("key").combine_chunks()
    dup = Duplicates(str(root))
    counts = pc.value_counts(keys)
    many = pc.filter(counts.field("values"), pc.greater(counts.field("counts"), 1))
    if len(many):
        hit = pa.array(np.flatnonzero(
            pc.is_in(keys, value_set=many).to_numpy(zero_copy_only=False)))
        shards = pc.take(t.column("__filename"), hit).to_pylist()
        for k, s in zip(keys.take(hit).to_pylist(), shards):
            s = _shard_id(s)
            if k not in dup.first or s < dup.first[k]:
                dup.first[k] = s
        dup.rows = len(hit) - len(dup.first)
    _DUPLICATES[str(root)] = (tuple(_stat_key(p) for p in files), dup)
    return keys


def duplicate_keys(root: str | Path) -> Duplicates:
    """The dataset's keys stored more than once (``Duplicates``; falsy when none). Cost: one read
    of the key column, remembered until a shard changes."""
    root = Path(root)
    files = shard_files(root)
    if not files:
        return Duplicates(str(root))
    known = _DUPLICATES.get(str(root))
    if known is None or known[0] != tuple(_stat_key(p) for p in files):
        _scan_keys(root, files)
    return _DUPLICATES[str(root)][1]


def existing_keys(root: str | Path) -> set[str]:
    """Content keys of every committed row (empty when there is no dataset yet); records the
    dataset's ``duplicate_keys`` on the way."""
    root = Path(root)
    files = shard_files(root)
    if not files:
        return set()
    return set(_scan_keys(root, files).to_pylist())


def read_table(root: str | Path, columns: list[str] | None = None, filter=None,
               unique: bool = False) -> pa.Table:
    """The rows of the dataset (``columns``, ``filter``: as ``pyarrow.dataset``) in shard order;
    ``unique``: each key's first row only (``Duplicates``). Raises ``CorruptShardError``."""
    root = Path(root)
    ds = open_dataset(root)
    dup = duplicate_keys(root) if unique else None
    with _reading(root):
        if not dup:
            return ds.to_table(columns=columns, filter=filter)
        cols = list(columns or SCHEMA.names)
        t = ds.scanner(columns=list(dict.fromkeys([*cols, "key", "__filename"])),
                       filter=filter).to_table()
    mask = dup.keep(t.column("key"), t.column("__filename"), set())
    return (t if mask is None else t.filter(pa.array(mask))).select(cols)


def count_rows(root: str | Path, filter=None, unique: bool = False) -> int:
    """How many rows ``read_table(root, filter=filter, unique=unique)`` has."""
    root = Path(root)
    ds = open_dataset(root)
    if unique and duplicate_keys(root):
        return read_table(root, ["key"], filter, unique=True).num_rows
    with _reading(root):
        return ds.count_rows(filter=filter)


def decode_images(column: pa.Array | pa.ChunkedArray) -> np.ndarray:
    """Fixed-size-binary image column -> uint8 array [N, 2, 64, 64] without per-row Python work."""
    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    buf = column.buffers()[1]
    start = column.offset * IMAGE_BYTES
    flat = np.frombuffer(buf, dtype=np.uint8, count=len(column) * IMAGE_BYTES, offset=start)
    return flat.reshape(len(column), 2, IMAGE_SIZE, IMAGE_SIZE)


def iter_shard_batches(path: str | Path, columns: list[str] | None = None, batch_size: int = 256,
                       filter=None, duplicates: Duplicates | None = None,
                       root: str | Path | None = None) -> Iterator[pa.RecordBatch]:
    """Record batches of one shard; with ``duplicates``, only the rows that ``Duplicates.keep``
    keeps. Raises ``CorruptShardError`` naming the shard."""
    path = Path(path)
    cols = list(columns or SCHEMA.names)
    need = cols if not duplicates or "key" in cols else [*cols, "key"]
    ds = pads.dataset(str(path), schema=SCHEMA, format="parquet")
    kept: set[str] = set()
    with _reading(Path(root) if root is not None else path.parent.parent):
        for rb in ds.to_batches(columns=need, batch_size=batch_size, filter=filter):
            if duplicates:
                mask = duplicates.keep(rb.column("key"), path, kept)
                if mask is not None:
                    rb = rb.filter(pa.array(mask))
                rb = rb.select(cols)
            yield rb


def iter_batches(root: str | Path, columns: list[str] | None = None, batch_size: int = 256,
                 filter=None, unique: bool = False) -> Iterator[pa.RecordBatch]:
    """Stream record batches from the dataset without loading it whole, in shard order;
    ``unique``: each key's first row only (``Duplicates``). Raises ``CorruptShardError``."""
    root = Path(root)
    ds = open_dataset(root)
    dup = duplicate_keys(root) if unique else None
    if not dup:
        with _reading(root):
            yield from ds.to_batches(columns=columns, batch_size=batch_size, filter=filter)
        return
    for f in ds.files:
        yield from iter_shard_batches(f, columns, batch_size, filter, dup, root)
