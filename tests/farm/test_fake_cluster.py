"""The farm on a real multi-node, autoscaling Ray on this machine (``tests/farm/fake_cluster.py``).

One fake cluster for the module: a head of 1 CPU, up to 3 worker nodes of 1 CPU that the
autoscaler adds for pending demand and removes after 6 s idle, its dashboard (Jobs API) on a free
port, token authentication on. The labelling runs use the real simulator behind the harness's
gate (a worker's first operation waits until every node has joined and every CPU is taken, then
each operation pauses 0.5 s), so that they outlast the nodes' arrival on a slow machine.

Select with ``-m cluster``; the module takes 3-5 minutes on 2 busy cores, so it is also ``slow``.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest

from rap.dataset import open_dataset

from tests.farm.conftest import ASSEMBLIES, FAKE, ROOT
from tests.farm.fake_cluster import RAY, FakeCluster, connected

pytestmark = [pytest.mark.ray, pytest.mark.cluster, pytest.mark.slow]

TWO = [str(ASSEMBLIES / "hexagon.json"), str(ASSEMBLIES / "rectilinear.json")]
SEED = 11
NODE = re.compile(r"^[^/]+/[0-9a-f]{56}$")  # hostname/<the whole Ray node id>


@pytest.fixture(scope="module")
def cluster():
    """The module's fake cluster, and this process connected to it (to watch its nodes)."""
    with connected(max_workers=3, idle_timeout_minutes=0.1, dashboard=True, gate_nodes=4, pause_s=0.5) as c:
        yield c


def label_cmd(c: FakeCluster, out, *extra: str, k: int = 24) -> list[str]:
    """``rap-farm label`` (with the harness's gated simulator) against the fake cluster."""
    return [sys.executable, str(ROOT / "tests" / "farm" / "fake_cluster.py"), "label", *TWO,
            "--out", str(out), "--address", c.address, "--trials", "5", "--seed", str(SEED),
            "--max-ops-per-assembly", str(k), "--quiet", *extra]


def rows(out) -> dict[str, tuple]:
    t = open_dataset(out).to_table(columns=["key", "node", "successes", "score"])
    keys = t.column("key").to_pylist()
    assert len(keys) == len(set(keys)), "a key was written twice"
    return dict(zip(keys, zip(t.column("node").to_pylist(), t.column("successes").to_pylist(),
                              t.column("score").to_pylist())))


def selected(stderr: str) -> int:
    """The number of operations ``label`` said it selected."""
    return int(re.search(r"(\d+) operations selected", stderr).group(1))


def test_label_starts_before_any_worker_node_and_uses_nodes_as_they_join(cluster, tmp_path):
    """Only the head's CPU exists: ``--workers 4 --start-timeout 5`` starts on it (no wait for
    nodes), asks the autoscaler for three more, and the rows come from every node."""
    assert len(cluster.alive_nodes()) == 1  # no worker node yet
    cluster.reset_gate()
    out = tmp_path / "ds"
    r = subprocess.run(label_cmd(cluster, out, "--workers", "4", "--start-timeout", "5"),
                       env=cluster.env, capture_output=True, text=True, timeout=600, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr[-3000:]
    got = rows(out)
    assert len(got) == selected(r.stderr) == 48
    nodes = {n for n, _, _ in got.values()}
    assert len(nodes) >= 3, nodes
    assert all(NODE.match(n) for n in nodes), nodes  # whole ids: the fake ones differ at the end
    assert f"nodes        {len(nodes)}, rows per node:" in r.stdout


def test_worker_node_killed_mid_run_loses_and_duplicates_no_row(cluster, tmp_path):
    """A worker node's raylet killed mid-run (spot preemption): exit 0, every operation exactly
    once, and the labels equal a local run's (``scripts/label_burst.py``, no Ray) with the same
    seed."""
    cluster.reset_gate()
    cluster.hold()  # the run cannot end before the node is killed (released after the kill)
    out = tmp_path / "ds"
    k = 30
    proc = subprocess.Popen(label_cmd(cluster, out, "--workers", "4", "--flush-rows", "2",
                                      "--flush-seconds", "1", k=k),
                            env=cluster.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=str(ROOT))
    try:
        victim = None
        deadline = time.monotonic() + 300
        while victim is None:  # the first worker node with committed rows
            assert proc.poll() is None, proc.communicate()[1][-3000:]
            assert time.monotonic() < deadline, "no worker node committed rows"
            time.sleep(0.5)
            if not out.exists() or not any(out.glob("*/*.parquet")):
                continue
            seen = {n for n, _, _ in rows(out).values()}
            for node in cluster.alive_nodes():
                if node["NodeID"] != FAKE_HEAD and any(s.endswith(node["NodeID"]) for s in seen):
                    victim = node
                    break
        os.kill(cluster.raylet_pid(victim), signal.SIGKILL)
        assert proc.poll() is None  # killed mid-run
        cluster.release()
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        cluster.release()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr[-3000:]
    assert "batches resubmitted" in stdout, stdout
    got = rows(out)
    assert len(got) == selected(stderr) == 2 * k  # none lost, none twice (rows() checks keys)
    assert any(n.endswith(victim["NodeID"]) for n, _, _ in got.values())

    local = tmp_path / "local"
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "label_burst.py"), *TWO,
                        "--out", str(local), "--processes", "1", "--minutes", "10",
                        "--trials", "5", "--seed", str(SEED), "--max-ops-per-assembly", str(k)],
                       env=cluster.env, capture_output=True, text=True, timeout=600, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr[-3000:]
    want = rows(local)
    assert {key: v[1:] for key, v in got.items()} == {key: v[1:] for key, v in want.items()}


FAKE_HEAD = "f" * 51 + "00000"  # the fake provider's head node id


def test_idle_actors_are_released_and_the_autoscaler_removes_their_nodes(cluster):
    from rap.farm.pool import SimPool
    from rap.io import load_assembly
    from rap.sim.params import SimParams

    from tests.farm import standin

    cluster.wait_nodes(lambda ns: len(ns) == 1)  # the earlier runs' nodes have gone
    grid = load_assembly(ASSEMBLIES / "grid.json")
    params = SimParams(trials=2)
    with SimPool(4, backend=FAKE, idle_timeout_s=2.0) as pool:
        started = pool.ready(timeout_s=300)  # all four: three nodes joined for them
        assert len({i["node"] for i in started}) == 4
        assert len(cluster.alive_nodes()) == 4
        ops = standin.operations(grid)
        keys = [r["key"] for res in pool.stream(SimPool.jobs(grid, ops, params, 3), params,
                                                images=False) for r in res.rows]
        assert sorted(keys) == sorted(set(keys)) and len(keys) == len(ops)
        deadline = time.monotonic() + 120
        while pool.size and time.monotonic() < deadline:
            time.sleep(0.5)
        assert pool.size == 0 and pool.stats["retired"] == 4
        nodes = cluster.wait_nodes(lambda ns: len(ns) == 1, timeout_s=300)
        assert nodes[0]["NodeID"] == FAKE_HEAD  # the autoscaler removed the idle worker nodes


def test_ray_job_submit_label_writes_the_dataset(cluster, tmp_path):
    """``ray job submit ... -- python jobs/label.py`` through the Jobs API with token auth on.

    Without ``--working-dir``: the nodes import the installed rap-farm, as on a cluster of the
    configs in cluster/. (With it, the fake nodes' runtime-env agents share one session directory
    and one of them can delete the unpacked package under another's workers: a fake-cluster
    artefact, seen here as ``FileNotFoundError`` for a module of the package.)"""
    out = tmp_path / "job-ds"
    cmd = [RAY, "job", "submit", "--address", cluster.dashboard_url, "--",
           "python", str(ROOT / "jobs" / "label.py"), str(ASSEMBLIES / "hexagon.json"),
           "--out", str(out),
           "--trials", "5", "--max-ops-per-assembly", "6", "--workers", "2", "--quiet"]
    r = subprocess.run(cmd, env=cluster.env, capture_output=True, text=True, timeout=600,
                       cwd=str(ROOT))
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    assert "succeeded" in r.stdout, r.stdout[-3000:]
    got = rows(out)
    assert len(got) == 6
    assert all(NODE.match(n) for n, _, _ in got.values())

    bad = dict(cluster.env, RAY_AUTH_TOKEN="0" * 64)  # token authentication is on
    r = subprocess.run([RAY, "job", "list", "--address", cluster.dashboard_url], env=bad,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode != 0
