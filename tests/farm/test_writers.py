"""`rap-farm label` and the dataset's faults: one writer per dataset (two concurrent runs, a killed
run), duplicate keys left by older runs, a corrupt shard quarantined and refilled, a full disk.

Each run uses the farm's stand-ins (``tests.farm.standin``: a known list of operations, fake
physics) on this module's small Ray; runs in other processes join it.
"""

from __future__ import annotations

import dataclasses
import errno
import os
import signal
import socket
import subprocess
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

import pyarrow.parquet as pq
import pytest

import rap.dataset as ds
from rap.dataset import open_dataset

from tests.farm.conftest import ASSEMBLIES, FAKE, ROOT, ray_env
from tests.test_check import run

pytestmark = pytest.mark.ray

TWO = (str(ASSEMBLIES / "grid.json"), str(ASSEMBLIES / "triangles.json"))

# `rap-farm label ...` in another process, on this module's Ray, with the stand-ins (a row a batch,
# a shard every 3 rows): held mid-run while the file $RAP_TEST_HOLD exists, each worker after its
# first $RAP_TEST_HOLD_AFTER operations (tests.farm.standin.held_simulate), so that the test, not
# the machine's speed, decides when the run may end.
_LABEL_SCRIPT = r"""
import dataclasses, sys
sys.path.insert(0, {root!r})
import rap.farm.driver as driver
import rap.farm.runtime as runtime
import rap.labelling.selection as selection
from tests.farm import standin
from tests.farm.conftest import FAKE
selection.select_operations = standin.select_operations
held = dataclasses.replace(FAKE, simulate="tests.farm.standin:held_simulate")
if standin.hold_env():  # the workers of the cluster joined get the hold through the job
    init = runtime.init_ray
    runtime.init_ray = lambda **kw: init(**kw, runtime_env={{"env_vars": standin.hold_env()}})
fix = lambda c: dataclasses.replace(c, backend=held, batch_size=1, flush_rows=3)
prepare, run = driver.prepare, driver.run_label
driver.prepare = lambda c, *a, **k: prepare(fix(c), *a, **k)
driver.run_label = lambda c, plan=None, **k: run(fix(c), plan, **k)
from rap.cli import main
main(sys.argv[1:])
"""


def argv(out, *extra) -> list[str]:
    return ["label", *TWO, "--out", str(out), "--trials", "3", "--seed", "5", "--workers", "2",
            "--max-ops-per-assembly", "0", "--quiet", *extra]


#: a held run has labelled at least this many rows: two shards of 3 (``_LABEL_SCRIPT``)
HOLD_AFTER = 6


def label_process(out, address, hold=None) -> subprocess.Popen:
    """``_LABEL_SCRIPT`` labelling ``TWO`` into ``out``; held while the file ``hold`` exists."""
    env = ray_env()
    if hold is not None:
        env.update(RAP_TEST_HOLD=str(hold), RAP_TEST_HOLD_AFTER=str(HOLD_AFTER))
    return subprocess.Popen([sys.executable, "-c", _LABEL_SCRIPT.format(root=str(ROOT)),
                             *argv(out, "--address", address)],
                            env=env, cwd=str(ROOT), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


@pytest.fixture
def in_process(ray_local, fake_enum, monkeypatch):
    """``rap.cli.main`` running ``label`` in this process with the stand-ins (fast fake physics)."""
    import rap.farm.driver as driver
    from rap.cli import main

    fix = lambda c: dataclasses.replace(c, backend=FAKE, flush_rows=4)  # noqa: E731
    prepare, run = driver.prepare, driver.run_label
    monkeypatch.setattr(driver, "prepare", lambda c, *a, **k: prepare(fix(c), *a, **k))
    monkeypatch.setattr(driver, "run_label", lambda c, plan=None, **k: run(fix(c), plan, **k))
    return main


def total_operations(standin) -> int:
    from rap.io import load_assembly

    return sum(len(standin.operations(load_assembly(p))) for p in TWO)


def rows(out) -> list[dict]:
    """The dataset's rows (without the node column) sorted by key."""
    return open_dataset(out).to_table().drop_columns(["node"]).sort_by("key").to_pylist()


def label(main, out, capsys, *extra) -> tuple[int, str, str]:
    return run(argv(out, *extra), capsys, main)


def killed_after(proc: subprocess.Popen, ready, timeout_s: float = 120.0) -> None:
    """SIGKILL ``proc`` as soon as ``ready()`` holds (it must still be running then)."""
    deadline = time.time() + timeout_s
    try:
        while not ready():
            assert proc.poll() is None, proc.stderr.read()[-2000:]
            assert time.time() < deadline, "not ready in time"
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)


def test_two_concurrent_runs_on_one_out_one_refused_naming_the_other_and_no_key_twice(
        ray_local, tmp_path):
    from tests.farm import standin

    address = ray_local.get_runtime_context().gcs_address
    out = tmp_path / "ds"
    hold = tmp_path / "hold"
    hold.touch()  # the run that takes the lock cannot end before the other has been refused
    procs = [label_process(out, address, hold) for _ in range(2)]
    try:
        with ThreadPoolExecutor(2) as pool:
            outputs = [pool.submit(p.communicate, timeout=240) for p in procs]
            wait(outputs, timeout=240, return_when=FIRST_COMPLETED)  # the refused one
            hold.unlink()
            done = [o.result() + (p.returncode,) for o, p in zip(outputs, procs)]
    finally:
        hold.unlink(missing_ok=True)
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait(30)
    codes = sorted(d[2] for d in done)
    assert codes == [0, 3], [d[1][-2000:] for d in done]
    winner = procs[[d[2] for d in done].index(0)]
    refused = done[[d[2] for d in done].index(3)]
    err = refused[1].strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"rap-farm: error: {out}: another run is writing this dataset "
                          f"(pid {winner.pid} on {socket.gethostname()}, started ")
    assert "rap-farm label" in err and "run again once it has finished" in err
    t = open_dataset(out).to_table(columns=["key"])
    keys = t.column("key").to_pylist()
    assert len(keys) == len(set(keys)) == total_operations(standin)  # 0 duplicated keys
    assert not ds.duplicate_keys(out) and not (out / ds.LOCK_FILE).exists()


def test_a_run_killed_with_sigkill_does_not_block_the_next(ray_local, tmp_path):
    from tests.farm import standin

    address = ray_local.get_runtime_context().gcs_address
    out = tmp_path / "ds"
    hold = tmp_path / "hold"
    hold.touch()  # the run cannot end before it is killed
    proc = label_process(out, address, hold)
    try:
        killed_after(proc, lambda: len(ds.shard_files(out)) >= 2)
    finally:
        hold.unlink()
    before = open_dataset(out).count_rows()
    total = total_operations(standin)
    assert 0 < before < total
    assert f'"pid": {proc.pid}' in (out / ds.LOCK_FILE).read_text()  # left behind, not held
    again = label_process(out, address)
    summary, err = again.communicate(timeout=240)
    assert again.returncode == 0, err[-2000:]
    assert f"{before} already present, {total - before} labelled now" in summary
    keys = open_dataset(out).to_table(columns=["key"]).column("key").to_pylist()
    assert len(keys) == len(set(keys)) == total
    assert not (out / ds.LOCK_FILE).exists() and not list(out.rglob(".tmp-*"))


def test_a_corrupt_shard_is_named_quarantined_and_its_rows_labelled_again(in_process, tmp_path,
                                                                         capsys):
    out = tmp_path / "ds"
    assert label(in_process, out, capsys)[0] == 0
    whole = rows(out)
    bad = ds.shard_files(out)[1]
    in_bad = pq.read_table(bad, columns=["key"]).column("key").to_pylist()
    bad.write_bytes(bad.read_bytes()[: bad.stat().st_size // 2])  # truncated
    code, _, err = label(in_process, out, capsys)
    assert code == 2 and err.strip().splitlines() == [
        f"rap-farm: error: {bad}: corrupt shard (Parquet magic bytes not found in footer. Either the "
        f"file is corrupted or this is not a parquet file.); `rap-farm check {out} --quarantine` "
        f"moves it aside and a rerun of `rap-farm label` refills its rows"]
    code, _, _ = run(["check", str(out)], capsys)
    assert code == 2 and bad.exists()
    code, _, _ = run(["check", str(out), "--quarantine"], capsys)
    assert code == 0 and not bad.exists()
    assert (out / ds.QUARANTINE_DIR / bad.parent.name / bad.name).exists()
    code, summary, err = label(in_process, out, capsys)
    assert code == 0, err
    assert f"{len(whole) - len(in_bad)} already present, {len(in_bad)} labelled now" in summary
    assert rows(out) == whole  # exactly the rows it held, the same keys and labels


def test_a_full_disk_while_labelling_is_one_line_with_status_3_and_resumes(in_process, tmp_path,
                                                                        capsys, monkeypatch):
    from tests.farm import standin

    out = tmp_path / "ds"
    write_table, calls = pq.write_table, []

    def full_after_one(*args, **kwargs):
        calls.append(1)
        if len(calls) > 1:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return write_table(*args, **kwargs)

    monkeypatch.setattr(pq, "write_table", full_after_one)
    code, _, err = label(in_process, out, capsys)
    selected, line = err.strip().splitlines()  # "88 operations selected ...", the error
    assert code == 3 and line.startswith(f"rap-farm: error: {out}/")
    assert ": cannot write: disk full; committed files are kept, no partial file is left" in line
    assert not list(out.rglob(".tmp-*")) and not (out / ds.LOCK_FILE).exists()
    (committed,) = ds.shard_files(out)  # the shard written before the disk filled, intact
    assert ds.shard_problem(committed) is None
    monkeypatch.setattr(pq, "write_table", write_table)
    code, summary, err = label(in_process, out, capsys)
    assert code == 0, err
    assert open_dataset(out).count_rows() == total_operations(standin)


def test_metadata_that_cannot_be_written_is_one_line_with_status_3(in_process, tmp_path, capsys,
                                                                   monkeypatch):
    out = tmp_path / "ds"

    def full(*args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    code, _, err = label(in_process, out, capsys)
    assert code == 3 and err.strip().splitlines()[1:] == [
        f"rap-farm: error: {out / ds.METADATA_FILE}: cannot write: disk full; committed files are "
        f"kept, no partial file is left"]
    assert not list(out.rglob(".tmp-*")) and not list(out.rglob("*.parquet"))


def test_label_on_a_dataset_with_duplicates_says_so_and_adds_none(in_process, tmp_path, capsys):
    out = tmp_path / "ds"
    assert label(in_process, out, capsys)[0] == 0
    n = open_dataset(out).count_rows()
    first = ds.shard_files(out)[0]
    copy = first.with_name("part-copy.parquet")  # as a second writer did before the lock
    copy.write_bytes(first.read_bytes())
    again = pq.read_metadata(copy).num_rows
    code, summary, err = label(in_process, out, capsys)
    assert code == 0, err
    assert f"{n} already present, 0 labelled now" in summary
    assert (f"duplicates   {again} rows of the dataset repeat a key stored before them (readers use "
            f"each key's first row); this run added none") in summary.splitlines()
    assert open_dataset(out).count_rows() == n + again and ds.duplicate_keys(out).rows == again


def test_readers_read_a_dataset_while_its_writer_holds_the_lock(ray_local, in_process, tmp_path,
                                                                capsys):
    import pandas as pd

    out = tmp_path / "ds"
    assert label(in_process, out, capsys)[0] == 0
    n = open_dataset(out).count_rows()
    with ds.lock_dataset(out, "a writer"):
        assert (out / ds.LOCK_FILE).exists()
        assert len(pd.read_parquet(out)) == n
        assert ray_local.data.read_parquet(str(out), file_extensions=["parquet"]).count() == n
        assert ds.read_table(out, ["key"]).num_rows == n
