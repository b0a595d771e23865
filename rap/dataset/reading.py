"""Reading a dataset: its shards, corrupt shards found and moved aside, keys stored twice, and
rows read whole or streamed (each key's first row with ``unique``)."""

from __future__ import annotations

import contextlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from rap.errors import InputError, one_line

from rap.dataset.schema import QUARANTINE_DIR, SCHEMA
from rap.dataset.storage import fsync_dir, storage_error

_SHARD_GLOB = "*/part-*.parquet"


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
    return re.sub(r"^Could not open Parquet input source '[^']*': ", "", one_line(exc))


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
            raise storage_error(dest, exc) from None
        fsync_dir(d)
        fsync_dir(p.parent)
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
