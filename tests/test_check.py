"""`rap-farm check DATASET [--quarantine]`: corrupt shards listed with the reason (exit 2), moved
aside with --quarantine (exit 0) under the dataset's lock (exit 3 while a writer runs), leftover
temporary files and duplicate keys reported. Refilling by `label` is tested in
tests/farm/test_writers.py."""

from __future__ import annotations

import json
import os
import socket

import pytest

import rap.dataset as ds
from rap.cli import main
from rap.dataset import rows_to_table, write_shard

from tests.test_dataset import row


@pytest.fixture
def dataset(tmp_path):
    root = tmp_path / "ds"
    ds.write_meta(root, ds.DatasetMeta(schema_version=ds.SCHEMA_VERSION, root_seed=1, params={},
                                       command="rap-farm label a.json --out ds"))
    for i in range(3):
        write_shard(root, rows_to_table([row(2 * i), row(2 * i + 1)]))
    return root


def run(argv, capsys, main=main) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``rap-farm ARGV`` run in this process by ``main``."""
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def test_a_clean_dataset(dataset, capsys):
    code, out, err = run(["check", str(dataset)], capsys)
    assert code == 0 and err == ""
    assert out.splitlines() == [f"{dataset}: 3 shards, 6 rows in the 3 that read, 0 corrupt"]


def test_corrupt_shards_are_listed_then_quarantined_and_the_rest_reads(dataset, capsys):
    shards = ds.shard_files(dataset)
    truncated, garbage = shards[0], shards[2]
    truncated.write_bytes(truncated.read_bytes()[:300])
    garbage.write_bytes(b"PAR1" + os.urandom(2000) + b"PAR1")
    (dataset / "a" / ".tmp-left.parquet").write_bytes(b"")
    before = {p: p.read_bytes() for p in dataset.rglob("*") if p.is_file()}
    code, out, err = run(["check", str(dataset)], capsys)
    lines = out.splitlines()
    assert code == 2 and lines[0] == f"{dataset}: 3 shards, 2 rows in the 1 that read, 2 corrupt"
    assert lines[1].startswith(f"corrupt      {truncated}: ") and "magic bytes" in lines[1]
    assert lines[2].startswith(f"corrupt      {garbage}: ")
    assert lines[3].startswith("temporary    1 .tmp-* files")
    assert err.strip() == (f"rap-farm: error: {dataset}: 2 corrupt shard(s); `rap-farm check "
                           f"{dataset} --quarantine` moves them aside and a rerun of `rap-farm "
                           f"label` refills their rows")
    assert {p: p.read_bytes() for p in dataset.rglob("*") if p.is_file()} == before  # read only
    code, out, err = run(["check", str(dataset), "--quarantine"], capsys)
    assert code == 0 and err == ""
    q = dataset / ds.QUARANTINE_DIR / "a"
    assert f"quarantined  {truncated} -> {q / truncated.name}" in out.splitlines()
    assert f"quarantined  {garbage} -> {q / garbage.name}" in out.splitlines()
    assert "removed      1 temporary files left by an interrupted writer" in out
    assert "rerun `rap-farm label a.json --out ds` to label the rows they held again" in out
    assert (q / truncated.name).read_bytes() == before[truncated]
    assert ds.shard_files(dataset) == [shards[1]] and not (dataset / ds.LOCK_FILE).exists()
    assert not list(dataset.rglob(".tmp-*"))
    code, out, _ = run(["check", str(dataset)], capsys)
    assert code == 0 and out.splitlines() == [
        f"{dataset}: 1 shards, 2 rows in the 1 that read, 0 corrupt"]


def test_quarantine_is_refused_while_a_writer_holds_the_lock(dataset, capsys):
    bad = ds.shard_files(dataset)[0]
    bad.write_bytes(b"garbage")
    with ds.lock_dataset(dataset, "rap-farm label x --out ds"):
        code, _, err = run(["check", str(dataset), "--quarantine"], capsys)
        assert code == 3 and bad.exists()
        assert err.startswith(f"rap-farm: error: {dataset}: another run is writing this dataset "
                              f"(pid {os.getpid()} on {socket.gethostname()}, started ")
        assert len(err.strip().splitlines()) == 1


def test_duplicate_keys_are_reported(dataset, capsys):
    write_shard(dataset, rows_to_table([row(0), row(1), row(2)]))
    code, out, _ = run(["check", str(dataset)], capsys)
    assert code == 0
    assert out.splitlines()[-1] == (f"duplicates   {dataset}: 3 duplicate rows (3 keys stored "
                                    f"more than once); each key's first row (by shard path, then "
                                    f"row) is used")


@pytest.mark.parametrize("make, message", [
    (lambda d: (d / ds.METADATA_FILE).write_text("[" * 100_000), "nested too deeply"),
    (lambda d: (d / ds.METADATA_FILE).write_text(json.dumps({"schema_version": 2})), "missing"),
])
def test_metadata_that_does_not_read_is_one_line(dataset, capsys, make, message):
    make(dataset)
    code, _, err = run(["check", str(dataset)], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_not_a_dataset(tmp_path, capsys):
    code, _, err = run(["check", str(tmp_path / "missing")], capsys)
    assert code == 2 and err.strip() == f"rap-farm: error: {tmp_path / 'missing'}: no such dataset directory"
    code, _, err = run(["check", str(tmp_path)], capsys)
    assert code == 2 and "not a rap-farm dataset" in err
