"""rap.dataset: schema 2 rows, atomic shards, schema-1 shards still readable; one writer at a time,
duplicate keys read once, corrupt shards named and quarantined, a full disk one line with no
temporary file left, metadata that does not read one line."""

from __future__ import annotations

import errno
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import rap.dataset as ds
from rap.dataset import SCHEMA, decode_images, open_dataset, rows_to_table, write_shard
from rap.errors import EXIT_FAILED, EXIT_INPUT, InputError, StorageError


def row(i: int, **extra) -> dict:
    r = {"key": f"k{i}", "assembly": "a", "geometry_hash": "g", "subassembly": "x,y", "moving": "x",
         "fixed": "y", "direction_x": 1.0, "direction_y": 0.0, "score": 0.5, "successes": 1,
         "trials": 2, "image": bytes([i % 256]) * 8192, "seed": i, "params": "{}",
         "code_version": "0", "node": "n"}
    r.update(extra)
    return r


def test_rows_round_trip_with_family_and_direction_index(tmp_path):
    write_shard(tmp_path, rows_to_table([row(0, family="wall", direction_index=2), row(1)]))
    t = open_dataset(tmp_path).to_table().sort_by("key")
    assert t.column("family").to_pylist() == ["wall", None]
    assert t.column("direction_index").to_pylist() == [2, None]
    assert decode_images(t.column("image"))[0, 0, 0, 0] == 0


def test_schema_1_shards_read_with_null_new_columns(tmp_path):
    v1 = pa.schema([f for f in SCHEMA if f.name not in ("family", "direction_index")])
    t = rows_to_table([row(3)]).select(v1.names).cast(v1)
    (tmp_path / "a").mkdir()
    pq.write_table(t, tmp_path / "a" / "part-old.parquet")
    back = open_dataset(tmp_path).to_table()
    assert back.num_rows == 1 and back.column("family").to_pylist() == [None]


def test_geometry_kept_beside_the_rows_once_and_replaced_when_other(tmp_path):
    from rap.dataset import GEOMETRY_DIR, write_geometry
    from rap.io import load_assembly

    root = Path(__file__).resolve().parents[1] / "assemblies"
    grid, hexagon = load_assembly(root / "grid.json"), load_assembly(root / "hexagon.json")
    assert write_geometry(tmp_path, [grid, hexagon]) == 2
    kept = tmp_path / GEOMETRY_DIR / "grid.json"
    assert load_assembly(kept).geometry_hash == grid.geometry_hash
    before = kept.stat().st_mtime_ns
    assert write_geometry(tmp_path, [grid]) == 0 and kept.stat().st_mtime_ns == before
    kept.write_text("{not json")  # unreadable: written again
    assert write_geometry(tmp_path, [grid]) == 1
    assert load_assembly(kept).geometry_hash == grid.geometry_hash
    (tmp_path / GEOMETRY_DIR / "hexagon.json").write_bytes(kept.read_bytes())  # other geometry
    assert write_geometry(tmp_path, [hexagon]) == 1
    assert load_assembly(tmp_path / GEOMETRY_DIR / "hexagon.json").geometry_hash == hexagon.geometry_hash


# -- one writer per dataset ----------------------------------------------------------------------
def test_a_second_writer_is_refused_naming_the_first_and_readers_still_read(tmp_path):
    root = tmp_path / "new" / "ds"  # missing, with a missing parent
    lock = ds.lock_dataset(root, "rap-farm label a.json --out ds")
    held = json.loads((root / ds.LOCK_FILE).read_text())
    assert held["pid"] == os.getpid() and held["host"] == socket.gethostname()
    with pytest.raises(ds.DatasetBusyError) as exc:
        ds.lock_dataset(root, "another")
    msg = str(exc.value)
    assert exc.value.exit_code == EXIT_FAILED and "\n" not in msg
    assert f"pid {os.getpid()} on {socket.gethostname()}" in msg and "rap-farm label a.json" in msg
    write_shard(root, rows_to_table([row(0), row(1)]))  # the holder writes; readers read
    import pandas as pd

    assert len(pd.read_parquet(root)) == 2 and open_dataset(root).count_rows() == 2
    lock.release()
    lock.release()  # idempotent
    assert not (root / ds.LOCK_FILE).exists() and not lock.held
    with ds.lock_dataset(root) as again:  # free again
        assert again.held
    assert not (root / ds.LOCK_FILE).exists()


def test_a_refused_or_released_lock_leaves_no_directory_it_made(tmp_path):
    root = tmp_path / "a" / "b"
    ds.lock_dataset(root).release()
    assert not (tmp_path / "a").exists()
    lock = ds.lock_dataset(tmp_path / "c")
    lock = None  # collected: released  # noqa: F841
    assert not (tmp_path / "c").exists()


def test_a_lock_left_by_a_killed_writer_does_not_block(tmp_path):
    root = tmp_path / "ds"
    code = ("import sys, time, rap.dataset as ds; "
            "lock = ds.lock_dataset(sys.argv[1], 'killed'); print('locked', flush=True); "
            "time.sleep(600)")
    p = subprocess.Popen([sys.executable, "-c", code, str(root)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        with pytest.raises(ds.DatasetBusyError, match=f"pid {p.pid} on"):
            ds.lock_dataset(root)
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    assert json.loads((root / ds.LOCK_FILE).read_text())["pid"] == p.pid  # left behind ...
    with ds.lock_dataset(root) as lock:  # ... and taken over: the kernel released the flock
        assert json.loads(lock.path.read_text())["pid"] == os.getpid()


def test_without_flock_a_stale_lock_of_a_dead_process_is_taken_over(tmp_path, monkeypatch):
    import fcntl

    def no_flock(fd, op):
        raise OSError(errno.ENOLCK, "no locks available")

    monkeypatch.setattr(fcntl, "flock", no_flock)
    root = tmp_path / "ds"
    root.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    (root / ds.LOCK_FILE).write_text(json.dumps({"pid": int(dead), "host": socket.gethostname()}))
    lock = ds.lock_dataset(root)  # its pid is no longer alive on this host: stale
    assert json.loads((root / ds.LOCK_FILE).read_text())["pid"] == os.getpid()
    with pytest.raises(ds.DatasetBusyError, match=f"pid {os.getpid()} on"):
        ds.lock_dataset(root)  # a live holder
    lock.release()
    assert not (root / ds.LOCK_FILE).exists()
    (root / ds.LOCK_FILE).write_text(json.dumps({"pid": int(dead), "host": "elsewhere"}))
    with pytest.raises(ds.DatasetBusyError, match=f"pid {dead} on elsewhere"):
        ds.lock_dataset(root)  # another host's process: cannot tell, refused


def test_a_lock_that_cannot_be_written_is_a_storage_error_and_leaves_nothing(tmp_path, monkeypatch):
    real_write = os.write

    def full(fd, data):
        if b'"pid"' in data:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    monkeypatch.setattr(os, "write", full)
    root = tmp_path / "ds"
    with pytest.raises(StorageError, match=f"^{root / ds.LOCK_FILE}: cannot write: disk full"):
        ds.lock_dataset(root)
    assert not root.exists()  # nor the directory it made
    monkeypatch.undo()
    with ds.lock_dataset(root) as lock:  # the failed attempt holds nothing
        assert lock.held


# -- duplicate keys --------------------------------------------------------------------------------
def duplicated(root: Path) -> Path:
    """Rows k0..k3 in one shard and k2..k5 in another (k2, k3 twice; node tells them apart),
    plus the same k4 twice inside a third table of assembly b."""
    write_shard(root, rows_to_table([row(i, node="one") for i in range(4)]))
    write_shard(root, rows_to_table([row(i, node="two") for i in range(2, 6)]))
    write_shard(root, rows_to_table([row(9, assembly="b", node="x"), row(9, assembly="b", node="y")]))
    return root


def first_nodes(root: Path) -> dict[str, str]:
    """key -> node of the row kept: the first by shard path, then by row."""
    out: dict[str, str] = {}
    for f in ds.shard_files(root):
        for k, n in zip(*pq.read_table(f, columns=["key", "node"]).to_pydict().values()):
            out.setdefault(k, n)
    return out


def test_duplicate_keys_are_counted_and_read_once_each(tmp_path):
    root = duplicated(tmp_path)
    dup = ds.duplicate_keys(root)
    assert dup.rows == 3 and sorted(dup.first) == ["k2", "k3", "k9"]
    assert f"{root}: 3 duplicate rows (3 keys stored more than once)" in dup.describe()
    want = first_nodes(root)
    t = ds.read_table(root, unique=True)
    assert t.num_rows == 7 and sorted(t["key"].to_pylist()) == sorted(want)
    assert dict(zip(t["key"].to_pylist(), t["node"].to_pylist())) == want
    batches = list(ds.iter_batches(root, columns=["key", "node"], batch_size=2, unique=True))
    got = {k: n for b in batches for k, n in zip(b["key"].to_pylist(), b["node"].to_pylist())}
    assert got == want and sum(b.num_rows for b in batches) == 7
    assert all(b.schema.names == ["key", "node"] for b in batches)
    only_a = pa.compute.field("assembly") == "a"
    assert ds.count_rows(root, unique=True) == 7 and ds.count_rows(root) == 10
    assert ds.count_rows(root, filter=only_a, unique=True) == 6
    assert ds.read_table(root, ["score"], filter=only_a, unique=True).num_rows == 6
    assert not ds.duplicate_keys(tmp_path / "none")  # no dataset: none
    assert ds.existing_keys(root) == set(want)


def test_a_dataset_without_duplicates_reads_as_before(tmp_path):
    write_shard(tmp_path, rows_to_table([row(i) for i in range(5)]))
    assert not ds.duplicate_keys(tmp_path)
    assert ds.read_table(tmp_path, unique=True).equals(open_dataset(tmp_path).to_table())


# -- corrupt shards --------------------------------------------------------------------------------
def test_a_truncated_shard_is_one_line_naming_it(tmp_path):
    good, bad = (write_shard(tmp_path, rows_to_table([row(i) for i in r]))[0]
                 for r in (range(3), range(3, 6)))
    bad.write_bytes(bad.read_bytes()[:500])
    for read in (open_dataset, ds.existing_keys, ds.duplicate_keys, ds.read_table,
                 lambda r: list(ds.iter_batches(r))):
        with pytest.raises(ds.CorruptShardError) as exc:
            read(tmp_path)
        msg = str(exc.value)
        assert msg.startswith(f"{bad}: corrupt shard (") and "\n" not in msg
        assert "rap-farm check" in msg and exc.value.exit_code == EXIT_INPUT
    assert ds.shard_problem(good) is None and "magic bytes" in ds.shard_problem(bad)
    assert [p for p, _ in ds.corrupt_shards(tmp_path)] == [bad]


def test_garbage_pages_behind_a_sound_footer_are_found_when_read(tmp_path):
    rng = np.random.default_rng(0)
    rows = [row(i, image=rng.integers(0, 256, 8192, dtype=np.uint8).tobytes()) for i in range(64)]
    bad = write_shard(tmp_path, rows_to_table(rows))[0]
    data = bytearray(bad.read_bytes())
    data[8:len(data) // 2] = b"\x5a" * (len(data) // 2 - 8)
    bad.write_bytes(bytes(data))
    assert pq.read_metadata(bad).num_rows == 64  # the footer reads
    with pytest.raises(ds.CorruptShardError, match=f"^{bad}: corrupt shard"):
        ds.read_table(tmp_path)
    with pytest.raises(ds.CorruptShardError, match=f"^{bad}: corrupt shard"):
        list(ds.iter_batches(tmp_path, columns=["image"]))
    assert ds.shard_problem(bad) is not None


def test_a_shard_of_another_schema_is_corrupt(tmp_path):
    (tmp_path / "a").mkdir()
    pq.write_table(pa.table({"key": [1, 2]}), tmp_path / "a" / "part-x.parquet")
    assert ds.shard_problem(tmp_path / "a" / "part-x.parquet") == "column 'key' is int64, not string"


def test_quarantined_shards_are_not_read_and_names_do_not_clash(tmp_path):
    bad = write_shard(tmp_path, rows_to_table([row(0)]))[0]
    good = write_shard(tmp_path, rows_to_table([row(1)]))[0]
    bad.write_bytes(b"garbage")
    (moved,) = ds.quarantine(tmp_path, [bad])
    assert moved == tmp_path / ds.QUARANTINE_DIR / "a" / bad.name and moved.read_bytes() == b"garbage"
    assert ds.shard_files(tmp_path) == [good] and open_dataset(tmp_path).count_rows() == 1
    import pandas as pd

    assert pd.read_parquet(tmp_path)["key"].tolist() == ["k1"]  # pandas skips _quarantine too
    bad.write_bytes(b"garbage again")  # the same name once more
    (again,) = ds.quarantine(tmp_path, [bad])
    assert again.name == f"{bad.stem}.1.parquet" and moved.read_bytes() == b"garbage"


# -- full disk, temporary files ----------------------------------------------------------------------
def enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def temporary_files(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if p.name.startswith(".tmp-")]


def test_a_full_disk_is_one_storage_error_naming_the_path_and_leaves_no_temporary_file(
        tmp_path, monkeypatch):
    committed = write_shard(tmp_path, rows_to_table([row(0)]))
    monkeypatch.setattr(pq, "write_table", enospc)
    with pytest.raises(StorageError) as exc:
        write_shard(tmp_path, rows_to_table([row(1)]))
    msg = str(exc.value)
    assert msg.startswith(f"{tmp_path / 'a'}/part-") and ": cannot write: disk full" in msg
    assert exc.value.exit_code == EXIT_FAILED and "\n" not in msg
    monkeypatch.undo()
    monkeypatch.setattr(os, "fsync", enospc)  # a write that fails at fsync: metadata, geometry
    meta = ds.DatasetMeta(schema_version=ds.SCHEMA_VERSION, root_seed=1, params={}, command="x")
    with pytest.raises(StorageError, match=f"^{tmp_path / ds.METADATA_FILE}: cannot write: disk full"):
        ds.write_meta(tmp_path, meta)
    monkeypatch.setattr(os, "replace", lambda *a: enospc())
    monkeypatch.setattr(os, "fsync", lambda fd: None)
    with pytest.raises(StorageError, match="cannot write: disk full"):
        ds.write_geometry(tmp_path, [_grid()])
    assert temporary_files(tmp_path) == []
    assert ds.shard_files(tmp_path) == committed and not (tmp_path / ds.METADATA_FILE).exists()


def test_other_os_errors_give_their_reason(tmp_path, monkeypatch):
    def read_only(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    with pytest.raises(StorageError, match="cannot write: Read-only file system"):
        write_shard(tmp_path, rows_to_table([row(0)]))


def _grid():
    from rap.io import load_assembly

    return load_assembly(Path(__file__).resolve().parents[1] / "assemblies" / "grid.json")


def test_a_real_full_file_system(tmp_path):
    """A 1 MiB tmpfs (root only; skipped where mounting is not permitted)."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        rng = np.random.default_rng(1)
        first = write_shard(mnt, rows_to_table([row(0)]))
        rows = [row(i, image=rng.integers(0, 256, 8192, dtype=np.uint8).tobytes())
                for i in range(1, 200)]  # 1.6 MB that does not compress
        with pytest.raises(StorageError, match=f"^{mnt / 'a'}/part-.*: cannot write: disk full"):
            write_shard(mnt, rows_to_table(rows))
        assert temporary_files(mnt) == [] and ds.shard_files(mnt) == first
        assert open_dataset(mnt).count_rows() == 1
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_clean_partial_files_covers_the_root_and_the_geometry(tmp_path):
    write_shard(tmp_path, rows_to_table([row(0)]))
    (tmp_path / ds.GEOMETRY_DIR).mkdir()
    left = [tmp_path / ".tmp-meta", tmp_path / "a" / ".tmp-x.parquet",
            tmp_path / ds.GEOMETRY_DIR / ".tmp-grid"]
    for p in left:
        p.write_bytes(b"")
    assert ds.clean_partial_files(tmp_path) == 3 and temporary_files(tmp_path) == []
    assert open_dataset(tmp_path).count_rows() == 1


# -- metadata that is not ----------------------------------------------------------------------------
@pytest.mark.parametrize("text, why", [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"schema_version": 2, "root_seed": 1, "params": ' + "[" * 50_000 + "]" * 50_000
     + ', "command": "x"}', "nested too deeply"),
    ("[1, 2]", "a JSON list, not an object"),
    ('{"schema_version": 2}', "missing root_seed, params, command"),
    ('{"schema_version": "2", "root_seed": 1, "params": {}, "command": "x"}',
     "schema_version is a JSON str, not int"),
    ('{"schema_version": 2, "root_seed": true, "params": {}, "command": "x"}',
     "root_seed is a JSON bool, not int"),
    ('{"schema_version": 2, "root_seed": 1, "params": {}, "command": "x", "extra": 1}',
     "unknown field 'extra'"),
    ("{not json", "Expecting property name"),
])
def test_metadata_that_does_not_read_is_one_line(tmp_path, text, why):
    (tmp_path / ds.METADATA_FILE).write_text(text)
    with pytest.raises(InputError) as exc:
        ds.read_meta(tmp_path)
    msg = str(exc.value)
    assert msg.startswith(f"{tmp_path / ds.METADATA_FILE}: not a rap-farm dataset metadata file (")
    assert why in msg and "\n" not in msg and len(msg) < 400


def test_binary_metadata_is_one_line(tmp_path):
    (tmp_path / ds.METADATA_FILE).write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(InputError, match="not a rap-farm dataset metadata file"):
        ds.read_meta(tmp_path)
