"""SIGTERM stops every long-running command as Ctrl-C does (docker, systemd, Kubernetes, SLURM,
``ray job stop`` send it): exit 130, one line on stderr, no traceback and no C++ dump, committed
work kept and a rerun resumes; ``serve`` drains and exits 0.

Each command runs in a subprocess and gets SIGTERM once it is observably mid-run (a committed
shard, an epoch's resume file, its simulation processes, its progress line): no timed assertion.
The commands that start Ray or torch take 20-40 s each on two busy cores (marked ``slow`` and
``e2e``: run by CI and ``python -m pytest -m e2e``, not by the default run); those that start Ray
are marked ``ray`` (tests/conftest.py runs them one at a time).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from rap.dataset import open_dataset

from tests.farm.conftest import ASSEMBLIES, ROOT, ray_env
from tests.ports import free_port


INTERRUPTED = "rap-farm: interrupted; committed work is kept"
NOISE = ("Traceback", "Exception ignored", "*** SIGTERM", "(raylet)", "Error in atexit")

#: ``rap-farm`` with the stand-in selection and the held stand-in simulator (tests/farm/standin.py)
LABEL = r"""
import dataclasses, sys
sys.path.insert(0, {root!r})
import rap.farm.driver as driver
import rap.labelling.selection as selection
from tests.farm import standin
from tests.farm.conftest import FAKE
selection.select_operations = standin.select_operations
held = dataclasses.replace(FAKE, simulate="tests.farm.standin:held_simulate")
config = driver.LabelConfig
driver.LabelConfig = lambda **kw: config(**dict(kw, backend=held, batch_size=1, num_cpus=2))
from rap.cli import main
main(sys.argv[1:])
"""


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "rap.cli", *args]


def sigterm_mid_run(cmd: list[str], ready, tmp_path: Path, env: dict | None = None,
                    timeout_s: float = 300.0) -> tuple[int, list[str], str]:
    """Run ``cmd``, send SIGTERM once ``ready(proc, its stderr and stdout so far)``; its exit
    status, the stderr lines written after the signal, and its whole stderr. A command still
    running 120 s after the signal fails the test with its signal dispositions at the signal
    (``/proc/PID/status``: a signal blocked or ignored there never arrives)."""
    err_path, out_path = (tmp_path / f"{s}-{time.monotonic_ns()}" for s in ("stderr", "stdout"))
    with open(err_path, "w") as err, open(out_path, "w") as out:
        proc = subprocess.Popen(cmd, cwd=str(ROOT), stdout=out, stderr=err,
                                env=dict(env or ray_env(), PYTHONUNBUFFERED="1"),
                                start_new_session=True)
    try:
        deadline = time.monotonic() + timeout_s
        while not ready(proc, err_path.read_text() + out_path.read_text()):
            assert proc.poll() is None, f"exited {proc.returncode}: {err_path.read_text()[-2000:]}"
            assert time.monotonic() < deadline, err_path.read_text()[-2000:]
            time.sleep(0.05)  # polls the files the command writes
        mark = err_path.stat().st_size  # bytes: the text after it is read as bytes, then decoded
        state = signal_state(proc.pid)
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            pytest.fail(f"still running 120 s after SIGTERM (its signals then: {state}): "
                        f"{err_path.read_text()[-2000:]}")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    data = err_path.read_bytes()
    return proc.returncode, data[mark:].decode().splitlines(), data.decode()


def signal_state(pid: int) -> str:
    """The signal masks of process ``pid`` (``SigBlk``, ``SigIgn``, ``SigCgt``), or why not."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            return ", ".join(line.strip() for line in fh if line.startswith(("SigBlk", "SigIgn",
                                                                             "SigCgt")))
    except OSError as exc:
        return f"unknown ({exc})"


def clean(text: str) -> None:
    assert not [n for n in NOISE if n in text], text[-3000:]


def children(pid: int) -> list[int]:
    out = []
    for p in os.listdir("/proc"):
        try:
            with open(f"/proc/{p}/stat") as fh:
                if int(fh.read().rsplit(")", 1)[1].split()[1]) == pid:
                    out.append(int(p))
        except (OSError, ValueError, IndexError):
            pass
    return out


@pytest.mark.ray
@pytest.mark.slow  # a Ray or torch start or two: 20-40 s
@pytest.mark.e2e  # not in the default run: python -m pytest -m e2e
def test_label_sigterm_keeps_the_rows_and_a_rerun_completes(tmp_path):
    out, hold = tmp_path / "ds", tmp_path / "hold"
    hold.touch()  # each worker labels two operations, then waits: the run is held mid-run
    env = dict(ray_env(), RAP_TEST_HOLD=str(hold))
    cmd = [sys.executable, "-c", LABEL.format(root=str(ROOT)), "label",
           str(ASSEMBLIES / "grid.json"), str(ASSEMBLIES / "triangles.json"), "--out", str(out),
           "--workers", "2", "--trials", "3", "--max-ops-per-assembly", "0", "--flush-rows", "1",
           "--quiet"]
    status, after, text = sigterm_mid_run(
        cmd, lambda p, err: any(out.glob("*/part-*.parquet")), tmp_path, env)
    assert status == 130, text[-3000:]
    assert after == [INTERRUPTED], text[-3000:]
    clean(text)
    kept = open_dataset(out).to_table(columns=["key"]).column("key").to_pylist()
    assert kept and len(kept) == len(set(kept))

    hold.unlink()
    r = subprocess.run(cmd, cwd=str(ROOT), env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    assert f"({len(kept)} rows already in" in r.stderr
    keys = open_dataset(out).to_table(columns=["key"]).column("key").to_pylist()
    total = int(r.stderr.split(" operations selected")[0].split()[-1])
    assert len(keys) == len(set(keys)) == total and set(kept) <= set(keys)


def test_plan_sigterm_exits_130_in_one_line(tmp_path):
    cmd = cli("plan", str(ASSEMBLIES / "hexagon.json"), "--method", "sim", "--trials", "5000",
              "--workers", "2", "--cache", str(tmp_path / "scores.json"))
    status, after, text = sigterm_mid_run(cmd, lambda p, err: children(p.pid), tmp_path)
    assert status == 130 and after == [INTERRUPTED], text[-3000:]
    clean(text)


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    from tests.model.model_fixtures import write_synthetic

    return write_synthetic(tmp_path_factory.mktemp("sigterm-ds"), n=96)


@pytest.mark.slow  # a Ray or torch start or two: 20-40 s
@pytest.mark.e2e  # not in the default run: python -m pytest -m e2e
def test_train_sigterm_keeps_the_epochs_and_the_same_command_resumes(small_dataset, tmp_path):
    model = tmp_path / "m.pt"
    resume = tmp_path / "m.pt.resume"
    cmd = cli("train", str(small_dataset), "--out", str(model), "--epochs", "4", "--device",
              "cpu", "--batch-size", "16", "--threads", "1")
    status, after, text = sigterm_mid_run(cmd, lambda p, err: resume.exists(), tmp_path)
    assert status == 130, text[-3000:]
    assert len(after) == 1 and after[0].startswith("rap-farm: interrupted; the epochs completed "
                                                   "are kept in"), text[-3000:]
    clean(text)
    r = subprocess.run(cmd, cwd=str(ROOT), env=ray_env(), capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "resumed from epoch" in r.stdout and model.is_file() and not resume.exists()


def test_evaluate_sigterm_exits_130_in_one_line(small_dataset, tmp_path):
    cmd = cli("evaluate", str(small_dataset), "--out", str(tmp_path / "report"), "--epochs", "50",
              "--no-ray", "--device", "cpu", "--no-save-models")
    # the first fold's first epoch is done: the folds are training. (Its plan of folds, printed
    # before torch's optimizer is imported and the rows are read, 3-13 s earlier, is not that.)
    status, after, text = sigterm_mid_run(cmd, lambda p, err: " epoch 1/50: " in err, tmp_path)
    assert status == 130 and after[-1:] == [INTERRUPTED], text[-3000:]
    assert not [line for line in after[:-1] if line.strip() and "epoch" not in line], text
    clean(text)


@pytest.mark.ray
@pytest.mark.slow  # a Ray or torch start or two: 20-40 s
@pytest.mark.e2e  # not in the default run: python -m pytest -m e2e
def test_experiment_sigterm_exits_130_in_one_line(small_dataset, tmp_path):
    """SIGTERM once the experiment has planned the first of its three assemblies (on Ray, with
    its pool of simulation actors)."""
    import shutil

    shapes = tmp_path / "assemblies"
    shapes.mkdir()
    for name in ("alpha", "beta", "gamma"):  # the synthetic dataset's names
        shutil.copy(ASSEMBLIES / "hexagon.json", shapes / f"{name}.json")
    cmd = cli("experiment", str(small_dataset), "--out", str(tmp_path / "report"),
              "--assemblies", str(shapes), "--models", str(tmp_path / "models"), "--methods",
              "sim", "--workers", "1")
    status, after, text = sigterm_mid_run(cmd, lambda p, out: " R=" in out, tmp_path)
    assert status == 130 and after == [INTERRUPTED], text[-3000:]
    clean(text)


@pytest.mark.ray
@pytest.mark.slow  # a Ray or torch start or two: 20-40 s
@pytest.mark.e2e  # not in the default run: python -m pytest -m e2e
def test_serve_sigterm_stops_taking_requests_and_exits_0(tmp_path):
    port = free_port()
    env = dict(ray_env(), RAP_CACHE=str(tmp_path / "cache.json"))
    env.pop("RAP_FARM_TOKEN", None)
    cmd = cli("serve", "--port", str(port), "--trials", "5", "--workers", "1", "--no-cache")

    def healthy() -> bool:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=5) as r:
                return r.status == 200
        except OSError:
            return False

    status, after, text = sigterm_mid_run(cmd, lambda p, err: "Ctrl-C stops it" in err
                                          and healthy(), tmp_path, env)
    assert status == 0, text[-3000:]
    assert after == ["stopping the planning service ..."], text[-3000:]
    clean(text)
    assert not healthy()
