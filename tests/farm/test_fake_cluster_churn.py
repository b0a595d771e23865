"""The farm under churn on Ray's fake autoscaling cluster (``tests/farm/fake_cluster.py``).

A head of 1 CPU and up to 3 worker nodes of 1 CPU, with the provider's node updaters left on: the
autoscaler marks the launches as failed and replaces the nodes again and again. On top of that a
killer thread of this test ends a worker node's raylet every few seconds (by process id, never
the head's). ``rap-farm label --workers 4`` (the real simulator, no gate) must still exit 0 with
every operation exactly once and the labels of a one-worker run with the same seed
(``scripts/label_burst.py --processes 1``, no Ray). The figures of a run are printed (``-s``) and
recorded in docs/CLUSTER.md ("The farm under churn").

Select with ``-m cluster -k churn``; about two minutes on two busy cores.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time

import pytest

from tests.farm.conftest import ROOT
from tests.farm.fake_cluster import FakeCluster, connected
from tests.farm.test_fake_cluster import FAKE_HEAD, SEED, TWO, label_cmd, rows, selected

pytestmark = [pytest.mark.ray, pytest.mark.cluster, pytest.mark.slow]

KILL_EVERY_S = 6.0


@pytest.fixture(scope="module")
def churning():
    with connected(max_workers=3, idle_timeout_minutes=0.1, node_updaters=True, pause_s=0.3) as c:
        yield c


def killer(c: FakeCluster, stop: threading.Event, killed: list[str]) -> None:
    """Every ``KILL_EVERY_S``, SIGKILL the raylet of one alive worker node (the oldest first)."""
    while not stop.wait(KILL_EVERY_S):
        try:
            nodes = [n for n in c.alive_nodes() if n["NodeID"] != FAKE_HEAD]
        except Exception:
            continue
        for node in sorted(nodes, key=lambda n: n["NodeID"]):
            try:
                os.kill(c.raylet_pid(node), signal.SIGKILL)
            except (LookupError, ProcessLookupError):
                continue
            killed.append(node["NodeID"])
            break


def test_label_under_churn_and_killed_raylets_loses_and_duplicates_nothing(churning, tmp_path):
    out, k = tmp_path / "ds", 60
    stop, killed = threading.Event(), []
    thread = threading.Thread(target=killer, args=(churning, stop, killed), daemon=True)
    t0 = time.monotonic()
    thread.start()
    try:
        r = subprocess.run(label_cmd(churning, out, "--workers", "4", "--start-timeout", "5",
                                     "--flush-rows", "4", k=k),
                           env=churning.env, capture_output=True, text=True, timeout=900,
                           cwd=str(ROOT))
    finally:
        stop.set()
        thread.join(30)
    seconds = time.monotonic() - t0
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    got = rows(out)  # no key twice
    assert len(got) == selected(r.stderr) == 2 * k  # none lost
    churn = re.search(r"^churn .*$", r.stdout, re.M)
    print(f"\nchurn run: {seconds:.0f} s, {len(killed)} raylets killed, "
          f"{len({n for n, _, _ in got.values()})} nodes wrote rows; "
          f"{churn.group(0) if churn else 'no churn line'}")
    print(r.stdout)
    assert killed, "the killer found no worker node to kill"

    one = tmp_path / "one"
    b = subprocess.run([sys.executable, str(ROOT / "scripts" / "label_burst.py"), *TWO,
                        "--out", str(one), "--processes", "1", "--minutes", "10",
                        "--trials", "5", "--seed", str(SEED), "--max-ops-per-assembly", str(k)],
                       env=churning.env, capture_output=True, text=True, timeout=900,
                       cwd=str(ROOT))
    assert b.returncode == 0, b.stderr[-3000:]
    want = rows(one)
    assert {key: v[1:] for key, v in got.items()} == {key: v[1:] for key, v in want.items()}
