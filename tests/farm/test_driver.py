"""The labelling driver end to end: dataset contents and readers, resume, interruption, workers."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pyarrow.dataset as pads
import pytest

from rap.dataset import METADATA_FILE, SCHEMA, decode_images, open_dataset, read_meta

from tests.farm.conftest import ASSEMBLIES, FAKE, REAL, ROOT, ray_env

pytestmark = pytest.mark.ray

TWO = (str(ASSEMBLIES / "grid.json"), str(ASSEMBLIES / "triangles.json"))


def cfg(out, **kw):
    from rap.farm.driver import LabelConfig

    base = dict(assemblies=TWO, out=str(out), trials=3, seed=11, max_ops_per_assembly=10,
                backend=REAL, progress=False, flush_rows=4, workers=2)
    base.update(kw)
    return LabelConfig(**base)


def table(out):
    """The dataset as a comparable list of rows (without the node column), sorted by key."""
    t = open_dataset(out).to_table().drop_columns(["node"]).sort_by("key")
    return t.to_pylist()


@pytest.fixture(scope="module")
def reference(ray_local, tmp_path_factory):
    """An uninterrupted run (the real selection: a seeded sample of 10 per assembly)."""
    import rap.farm.driver as driver

    out = tmp_path_factory.mktemp("ref") / "ds"
    s = driver.run_label(cfg(out))
    return out, s


def test_dataset_rows_schema_and_readers(reference, ray_local):
    out, s = reference
    assert s.labelled == s.total == 20 and s.existing == 0 and s.duplicates == 0
    ds = pads.dataset(str(out), format="parquet", exclude_invalid_files=True)
    t = ds.to_table()
    assert t.num_rows == 20
    assert open_dataset(out).schema.equals(SCHEMA, check_metadata=False)
    assert set(t.column("assembly").to_pylist()) == {"grid", "triangles"}
    assert set(t.column("family").to_pylist()) == {"reference"}  # from the assembly files
    assert set(t.column("direction_index").to_pylist()) == {0}  # one direction per range
    assert (out / METADATA_FILE).exists()
    from rap.io import load_assembly

    for path in TWO:  # the geometry beside the rows: views and descriptors from the dataset alone
        a = load_assembly(path)
        assert load_assembly(out / "_assemblies" / f"{a.name}.json").geometry_hash == a.geometry_hash
    imgs = decode_images(open_dataset(out).to_table(columns=["image"]).column("image"))
    assert imgs.shape == (20, 2, 64, 64)
    rows = t.to_pylist()
    for r in rows:
        assert r["trials"] == 3 and 0 <= r["successes"] <= 3
        assert r["score"] == r["successes"] / r["trials"]
        assert json.loads(r["params"])["trials"] == 3
        assert r["node"] and r["code_version"]
    assert len({r["key"] for r in rows}) == 20
    mask = os.umask(0)
    os.umask(mask)
    for f in [out / METADATA_FILE, *out.glob("*/part-*.parquet"), *out.glob("_assemblies/*")]:
        assert f.stat().st_mode & 0o777 == 0o666 & ~mask, f
    meta = read_meta(out)
    assert meta.root_seed == 11 and meta.params["trials"] == 3 and "label" in meta.command

    import pandas as pd

    df = pd.read_parquet(out)
    assert len(df) == 20 and set(df["assembly"]) == {"grid", "triangles"}
    rd = ray_local.data.read_parquet(str(out), file_extensions=["parquet"])
    assert rd.count() == 20
    assert set(rd.select_columns(["assembly"]).unique("assembly")) == {"grid", "triangles"}


def test_resume_adds_nothing_twice(reference, ray_local, standin_enum, tmp_path):
    import rap.farm.driver as driver

    out = tmp_path / "copy"
    shutil.copytree(reference[0], out)
    before = table(out)
    s = driver.run_label(cfg(out))
    assert s.labelled == 0 and s.existing == 20
    assert table(out) == before
    # a bigger sample only adds the new operations (the sample for 10 is inside the one for 12)
    s = driver.run_label(cfg(out, max_ops_per_assembly=12))
    assert s.labelled == 4 and s.existing == 20
    after = table(out)
    assert len(after) == 24 and len({r["key"] for r in after}) == 24
    assert [r for r in after if r["key"] in {b["key"] for b in before}] == before


def test_interrupted_then_resumed_equals_uninterrupted(reference, ray_local, standin_enum, tmp_path):
    import rap.farm.driver as driver

    out = tmp_path / "ds"
    calls = []

    def boom(summary):
        calls.append(summary.labelled)
        if summary.labelled >= 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        driver.run_label(cfg(out, workers=1), on_batch=boom)
    partial = table(out)
    assert 4 <= len(partial) < 20  # committed on the way out
    assert not list(out.glob("*/.tmp-*"))
    s = driver.run_label(cfg(out, workers=2))
    assert s.existing == len(partial) and s.labelled == 20 - len(partial)
    assert table(out) == table(reference[0])  # same rows, same scores


def test_scores_do_not_depend_on_worker_count(reference, ray_local, standin_enum, tmp_path):
    import rap.farm.driver as driver

    out = tmp_path / "one"
    driver.run_label(cfg(out, workers=1, batch_size=7, flush_rows=100))
    assert table(out) == table(reference[0])


# a run held mid-run (tests.farm.standin.held_simulate: each worker after 6 operations, while the
# file $RAP_TEST_HOLD exists), so that it is killed with two shards written whatever the speed
_KILL_SCRIPT = r"""
import sys, dataclasses
sys.path.insert(0, {root!r})
import ray
from tests.farm import standin
ray.init(address={address!r},
         runtime_env={{"env_vars": {{"PYTHONPATH": {root!r}, **standin.hold_env()}}}},
         log_to_driver=False)
import rap.farm.driver as driver
import rap.labelling.selection as selection
from tests.farm.conftest import FAKE
selection.select_operations = standin.select_operations
held = dataclasses.replace(FAKE, simulate="tests.farm.standin:held_simulate")
cfg = driver.LabelConfig(assemblies={assemblies!r}, out={out!r}, trials=3, seed=5, backend=held,
                         progress=False, flush_rows=3, workers=2, batch_size=1)
driver.run_label(cfg)
"""


def test_driver_sigkill_leaves_no_partial_files_and_rerun_completes(ray_local, fake_enum, tmp_path):
    """SIGKILL the driver mid-run (it joined this module's cluster), then rerun to completion."""
    import rap.farm.driver as driver

    address = ray_local.get_runtime_context().gcs_address
    out = tmp_path / "killed"
    script = _KILL_SCRIPT.format(root=str(ROOT), assemblies=TWO, out=str(out), address=address)
    hold = tmp_path / "hold"
    hold.touch()
    env = dict(ray_env(), RAP_TEST_HOLD=str(hold), RAP_TEST_HOLD_AFTER="6")
    proc = subprocess.Popen([sys.executable, "-c", script], env=env, cwd=str(ROOT),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.time() + 90
        while len(list(out.glob("*/part-*.parquet"))) < 2:  # polls the files it commits
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            assert time.time() < deadline, "no two shards in 90 s"
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        hold.unlink()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    n_partial = open_dataset(out).count_rows()
    from rap.io import load_assembly

    total = sum(len(fake_enum.operations(load_assembly(p))) for p in TWO)
    assert 0 < n_partial < total
    # every visible shard is complete and readable
    for f in out.glob("*/part-*.parquet"):
        pads.dataset(str(f), format="parquet").to_table()
    c = dataclasses.replace(cfg(out), seed=5, trials=3, max_ops_per_assembly=None, backend=FAKE,
                            flush_rows=50)
    s = driver.run_label(c)
    assert s.existing == n_partial
    assert not list(out.glob("*/.tmp-*"))
    ref = tmp_path / "ref"
    driver.run_label(dataclasses.replace(c, out=str(ref)))
    assert table(out) == table(ref)


def test_cli_label_prints_summary_and_resumes(ray_local, standin_enum, monkeypatch, tmp_path, capsys):
    """``rap-farm label`` in-process on this module's Ray (``connect`` reuses it)."""
    import rap.farm.driver as driver
    from rap.cli import main

    run = driver.run_label
    monkeypatch.setattr(driver, "run_label",
                        lambda c, plan=None, **kw: run(dataclasses.replace(c, backend=REAL), plan, **kw))
    from rap.farm.pool import SimPool

    ready, waits = SimPool.ready, []
    monkeypatch.setattr(SimPool, "ready",
                        lambda self, t=120.0, **kw: waits.append((t, kw)) or ready(self, t, **kw))
    out = tmp_path / "cli"
    argv = ["label", TWO[0], "--out", str(out), "--preset", "tiny", "--max-ops-per-assembly", "5",
            "--trials", "2", "--quiet", "--start-timeout", "90"]
    main(argv)
    assert waits == [(90.0, {"at_least": 1})]  # --start-timeout: until one worker runs
    cap = capsys.readouterr()
    assert "5 operations selected in 1 assemblies (0 rows already in" in cap.err
    assert "5 labelled now" in cap.out and "score histogram" in cap.out and "ops/s" in cap.out
    main(argv)
    cap = capsys.readouterr()
    assert "(5 rows already in" in cap.err and "5 already present, 0 labelled now" in cap.out
    assert open_dataset(out).count_rows() == 5
    assert read_meta(out).params["trials"] == 2
