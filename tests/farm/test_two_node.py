"""A real two-node Ray cluster on this machine (``ray start`` twice), labelled through --address.

Both nodes run with token authentication (``RAY_AUTH_MODE=token`` and a throwaway
``RAY_AUTH_TOKEN``), on 127.0.0.1 only, in a private ``--temp-dir``; the ``ray start --block``
processes are ours and are stopped by pid in teardown (never a machine-wide ``ray stop``, which
would also stop other people's clusters).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import pytest

from rap.dataset import open_dataset

from tests.farm.conftest import ASSEMBLIES, ROOT, ray_env
from tests.farm.fake_cluster import RAY
from tests.ports import free_port

pytestmark = [pytest.mark.ray, pytest.mark.e2e]  # not in the default run: python -m pytest -m e2e


def alive_nodes(address: str, env: dict) -> int:
    code = ("import ray; ray.init(address=%r, log_to_driver=False, logging_level='ERROR'); "
            "print(sum(1 for n in ray.nodes() if n['Alive']))" % address)
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=120)
    return int(r.stdout.strip().splitlines()[-1]) if r.returncode == 0 and r.stdout.strip() else 0


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)


@pytest.fixture(scope="module")
def two_nodes():
    import ray

    if ray.is_initialized():
        ray.shutdown()
    tmp = tempfile.mkdtemp(prefix="rf2n-", dir="/tmp")  # short: Ray's socket paths are limited
    port = free_port()
    address = f"127.0.0.1:{port}"
    # the workers label with fake_cluster.GATED: their first operation waits for both nodes' actors
    env = dict(ray_env(), RAP_TEST_GATE_NODES="2", RAP_TEST_GATE_FILE=os.path.join(tmp, "gate"))
    common = ["--num-cpus", "1", "--node-ip-address", "127.0.0.1", "--block",
              "--disable-usage-stats", "--temp-dir", tmp]
    procs = []
    try:
        procs.append(subprocess.Popen(
            [RAY, "start", "--head", "--port", str(port), "--include-dashboard", "false", *common],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        deadline = time.time() + 120
        while alive_nodes(address, env) < 1:
            assert procs[0].poll() is None and time.time() < deadline, "head did not start"
            time.sleep(1)
        procs.append(subprocess.Popen(
            [RAY, "start", "--address", address, *common],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        while alive_nodes(address, env) < 2:
            assert procs[1].poll() is None and time.time() < deadline, "worker node did not start"
            time.sleep(1)
        yield address, env
    finally:
        for p in reversed(procs):
            stop(p)
        shutil.rmtree(tmp, ignore_errors=True)


def test_label_through_address_on_two_nodes(two_nodes, tmp_path):
    address, env = two_nodes
    out = tmp_path / "ds"
    cmd = [sys.executable, str(ROOT / "tests" / "farm" / "fake_cluster.py"), "label",
           str(ASSEMBLIES / "grid.json"), str(ASSEMBLIES / "hexagon.json"), "--out", str(out),
           "--address", address, "--workers", "2", "--trials", "3", "--max-ops-per-assembly", "8",
           "--quiet", "--flush-rows", "4"]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr[-3000:]
    t = open_dataset(out).to_table(columns=["key", "node"])
    assert t.num_rows == 16 and len(set(t.column("key").to_pylist())) == 16
    nodes = set(t.column("node").to_pylist())
    assert len(nodes) == 2, nodes  # both nodes labelled rows
    assert "nodes" in r.stdout


def test_wrong_token_is_refused(two_nodes, tmp_path):
    """Token authentication is on: a driver with another token cannot join."""
    address, env = two_nodes
    bad = dict(env, RAY_AUTH_TOKEN="0" * 64)
    out = tmp_path / "ds"
    r = subprocess.run([sys.executable, str(ROOT / "tests" / "farm" / "cli_standins.py"), "label",
                        str(ASSEMBLIES / "grid.json"), "--out", str(out), "--address", address,
                        "--trials", "2", "--max-ops-per-assembly", "2", "--quiet"],
                       env=bad, capture_output=True, text=True, timeout=180, cwd=str(ROOT))
    assert r.returncode == 2, r.stderr[-2000:]
    err = r.stderr.strip().splitlines()
    assert err[-1].startswith("rap-farm: error: cannot start or reach"), r.stderr[-2000:]
    assert not out.exists()
