"""A Ray cluster of several nodes on this machine for tests: Ray's fake autoscaling provider.

``FakeCluster(max_workers=3)`` writes an autoscaling config (provider ``fake_multinode``, a head
node type and a worker node type of ``worker_cpus`` logical CPUs each, ``min_workers: 0``) and
starts ``RAY_FAKE_CLUSTER=1 ray start --head --autoscaling-config=FILE --block`` in a session and
a temporary directory of its own, on free ports (GCS, dashboard, client server, dashboard agent).
The autoscaler (the head's monitor process) then starts a worker node, a raylet of its own in the
same temporary directory, for each pending demand of a CPU, and removes it after
``idle_timeout_minutes`` without work, as a cloud provider's autoscaler would. Nodes join the GCS
at ``127.0.0.1:PORT`` (the provider's ``gcs_address``), so nothing depends on 6379 being free.

Every process of the cluster carries ``RAP_FAKE_CLUSTER_ID=<id>`` in its environment; ``stop()``
kills the head's process tree and every process with that mark (worker processes, which Ray puts
in process groups of their own), by process id: never ``ray stop``, which stops every Ray on the
machine, other people's included. ``stop()`` also runs at interpreter exit.

Token authentication stays on: the cluster and its clients get ``RAY_AUTH_MODE=token`` and the
throwaway ``RAY_AUTH_TOKEN`` of ``tests/farm/conftest.py`` (``env``).

``python tests/farm/fake_cluster.py label ...`` is ``rap-farm label ...`` with ``GATED``, the real
simulator behind a gate: a worker's first operation waits until ``RAP_TEST_GATE_NODES`` nodes are
alive and every CPU of the cluster is taken (all actors placed), once for the whole cluster (a
file marks the gate open), then each operation pauses ``RAP_TEST_PAUSE_S``. A run thus outlasts
the nodes' arrival whatever the machine's speed, without a timed assertion; labels are the real
simulator's. While ``hold()``'s file exists, a worker process's operations after its first
``HOLD_AFTER`` wait (``release()`` removes it): a test that must act on a run mid-run (kill a
node) holds it there instead of hoping the pauses last long enough.
"""

from __future__ import annotations

import contextlib

import atexit
import dataclasses
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from rap.labelling.rows import Backend  # noqa: E402
from tests.ports import free_port  # noqa: E402

__all__ = ["FakeCluster", "GATED", "gated_simulate"]

RAY = str(Path(sys.executable).with_name("ray"))
MARK = "RAP_FAKE_CLUSTER_ID"
HOLD_AFTER = 3  # a held worker process simulates this many operations, then waits (module doc)

#: the real simulator (renderer, warm-up) behind the gate described in the module docstring
GATED = Backend(simulate="tests.farm.fake_cluster:gated_simulate",
                render="rap.render.images:render_pair", warm_up="rap.sim.simulator:warm_up")


def _config(gcs: str, max_workers: int, min_workers: int, head_cpus: int, worker_cpus: int,
            idle_timeout_minutes: float, node_updaters: bool = False) -> str:
    """The autoscaling config (YAML is a superset of JSON; the launcher's fields are all given)."""
    import json

    cfg = {
        "cluster_name": "rapfake",
        "max_workers": max_workers,
        "upscaling_speed": 1.0,
        "idle_timeout_minutes": idle_timeout_minutes,
        "provider": {"type": "fake_multinode", "gcs_address": gcs, "use_node_id_as_ip": True,
                     "disable_node_updaters": not node_updaters,
                     "disable_launch_config_check": True},
        "available_node_types": {
            "ray.head.default": {"resources": {"CPU": head_cpus}, "node_config": {},
                                 "max_workers": 0},
            "ray.worker.cpu": {"resources": {"CPU": worker_cpus,
                                             "object_store_memory": 100 * 1024 ** 2},
                               "node_config": {}, "min_workers": min_workers,
                               "max_workers": max_workers},
        },
        "head_node_type": "ray.head.default",
        "auth": {}, "docker": {}, "file_mounts": {}, "cluster_synced_files": [],
        "file_mounts_sync_continuously": False, "rsync_exclude": [], "rsync_filter": [],
        "initialization_commands": [], "setup_commands": [], "head_setup_commands": [],
        "worker_setup_commands": [], "head_start_ray_commands": [],
        "worker_start_ray_commands": [],
    }
    return json.dumps(cfg, indent=1)


def _ppid(pid: str) -> int | None:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return int(fh.read().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return None


def _marked(pid: str, mark: bytes) -> bool:
    try:
        with open(f"/proc/{pid}/environ", "rb") as fh:
            return mark in fh.read().split(b"\0")
    except OSError:
        return False


def _cmdline(pid: int | str) -> list[str]:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return [a.decode(errors="replace") for a in fh.read().split(b"\0") if a]
    except OSError:
        return []


class FakeCluster:
    """See the module docstring. ``min_workers``: worker nodes the autoscaler keeps (started at
    once); ``gate_nodes``/``pause_s`` configure ``GATED`` on its workers; ``node_updaters``:
    leave the provider's node updaters on, so that the autoscaler marks launches as failed and
    replaces their nodes again and again (churn, as on a troubled spot cluster)."""

    def __init__(self, max_workers: int = 3, *, min_workers: int = 0, head_cpus: int = 1,
                 worker_cpus: int = 1,
                 idle_timeout_minutes: float = 0.1, dashboard: bool = False,
                 gate_nodes: int = 0, pause_s: float = 0.0, env: dict | None = None,
                 node_updaters: bool = False):
        self.max_workers, self.min_workers = max_workers, min_workers
        self.node_updaters = node_updaters
        self.head_cpus, self.worker_cpus = head_cpus, worker_cpus
        self.idle_timeout_minutes = idle_timeout_minutes
        self.dashboard = dashboard
        self.id = uuid.uuid4().hex
        self.tmp = Path(tempfile.mkdtemp(prefix="rffc-", dir="/tmp"))  # short: socket path limits
        self.port = free_port()
        self.dashboard_port = free_port()
        self.address = f"127.0.0.1:{self.port}"
        self.dashboard_url = f"http://127.0.0.1:{self.dashboard_port}"
        self.gate_file = self.tmp / "gate-open"
        self.hold_file = self.tmp / "hold"
        base = dict(os.environ if env is None else env)
        path = [str(ROOT), base.get("PYTHONPATH", "")]
        base["PYTHONPATH"] = os.pathsep.join(path).rstrip(os.pathsep)
        base["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), base.get("PATH", "")])
        base.update(RAY_AUTH_MODE="token", RAY_USAGE_STATS_ENABLED="0")
        base.pop("RAY_ADDRESS", None)
        #: the environment of a client of this cluster (driver, ``ray job submit``, ``ray status``)
        self.env = base
        self._cluster_env = dict(base, RAY_FAKE_CLUSTER="1", RAP_TEST_GATE_NODES=str(gate_nodes),
                                 RAP_TEST_PAUSE_S=str(pause_s),
                                 RAP_TEST_GATE_FILE=str(self.gate_file),
                                 RAP_TEST_HOLD_FILE=str(self.hold_file), **{MARK: self.id})
        self.head: subprocess.Popen | None = None
        self._stopped = False
        atexit.register(self.stop)

    # -- life cycle ------------------------------------------------------------------------------
    def start(self, timeout_s: float = 120.0) -> "FakeCluster":
        cfg = self.tmp / "autoscaling.yaml"
        cfg.write_text(_config(self.address, self.max_workers, self.min_workers, self.head_cpus,
                               self.worker_cpus, self.idle_timeout_minutes,
                               self.node_updaters))
        cmd = [RAY, "start", "--head", f"--autoscaling-config={cfg}", "--port", str(self.port),
               "--node-ip-address", "127.0.0.1", "--num-cpus", str(self.head_cpus),
               "--temp-dir", str(self.tmp / "ray"), "--disable-usage-stats", "--block",
               "--dashboard-port", str(self.dashboard_port), "--dashboard-host", "127.0.0.1",
               "--include-dashboard", "true" if self.dashboard else "false",
               "--ray-client-server-port", str(free_port()),
               "--dashboard-agent-listen-port", str(free_port())]
        log = open(self.tmp / "head.log", "wb")
        self.head = subprocess.Popen(cmd, env=self._cluster_env, stdout=log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        log.close()
        deadline = time.monotonic() + timeout_s
        while not self._answers():
            if self.head.poll() is not None or time.monotonic() > deadline:
                tail = (self.tmp / "head.log").read_text(errors="replace")[-2000:]
                self.stop()
                raise RuntimeError(f"the fake cluster's head did not start:\n{tail}")
            time.sleep(1.0)
        return self

    def _answers(self) -> bool:
        r = subprocess.run([RAY, "status", "--address", self.address], env=self.env,
                           capture_output=True, text=True, timeout=60)
        return r.returncode == 0 and "ray.head.default" in r.stdout

    def stop(self) -> None:
        """Kill every process of this cluster by process id, then remove its directory."""
        if self._stopped:
            return
        self._stopped = True
        mark = f"{MARK}={self.id}".encode()
        me = {os.getpid(), os.getppid()}
        for sig in (signal.SIGTERM, signal.SIGKILL):
            pids = set()
            children: dict[int, list[int]] = {}
            for p in os.listdir("/proc"):
                if p.isdigit():
                    children.setdefault(_ppid(p) or 0, []).append(int(p))
                    if _marked(p, mark):
                        pids.add(int(p))
            stack = [self.head.pid] if self.head is not None else []
            while stack:  # the head's tree (before the marks: a process may not be readable yet)
                p = stack.pop()
                pids.add(p)
                stack += children.get(p, [])
            for p in pids - me:
                try:
                    os.kill(p, sig)
                except (ProcessLookupError, PermissionError):
                    pass
            if sig == signal.SIGTERM:
                end = time.monotonic() + 10
                while time.monotonic() < end and any(_alive(p) for p in pids - me):
                    time.sleep(0.2)
        if self.head is not None:
            try:
                self.head.wait(10)
            except subprocess.TimeoutExpired:
                pass
        shutil.rmtree(self.tmp, ignore_errors=True)

    def leftovers(self) -> list[int]:
        """Processes of this cluster still running (after ``stop()``: none)."""
        mark = f"{MARK}={self.id}".encode()
        return [int(p) for p in os.listdir("/proc") if p.isdigit() and _marked(p, mark)]

    def __enter__(self) -> "FakeCluster":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- looking at it (Ray connected to this cluster in the calling process) --------------------
    def connect(self) -> None:
        """``ray.init`` in this process against the cluster, with token authentication. Ray turns
        token mode on by itself only for a cluster it finds without an address; with one, it
        takes ``RAY_AUTH_MODE`` as its config read it, so this sets it and reloads the config,
        as Ray does for a local cluster (``_enable_token_auth``)."""
        import ray
        from ray._private.authentication.authentication_token_setup import _enable_token_auth

        if "RAY_AUTH_TOKEN" in self.env:  # else both read ~/.ray/auth_token
            os.environ.setdefault("RAY_AUTH_TOKEN", self.env["RAY_AUTH_TOKEN"])
        _enable_token_auth()
        ray.init(address=self.address, log_to_driver=False, logging_level="ERROR")

    @staticmethod
    def alive_nodes() -> list[dict]:
        import ray

        return [n for n in ray.nodes() if n.get("Alive")]

    def wait_nodes(self, predicate, timeout_s: float = 180.0) -> list[dict]:
        """Poll ``alive_nodes()`` until ``predicate(nodes)``; ``AssertionError`` at the timeout."""
        deadline = time.monotonic() + timeout_s
        while True:
            nodes = self.alive_nodes()
            if predicate(nodes):
                return nodes
            assert time.monotonic() < deadline, f"nodes never reached the state: {len(nodes)} alive"
            time.sleep(1.0)

    def raylet_pid(self, node: dict) -> int:
        """The process id of ``node``'s raylet (an entry of ``ray.nodes()``)."""
        want = f"--raylet_socket_name={node['RayletSocketName']}"
        mark = f"{MARK}={self.id}".encode()
        for p in os.listdir("/proc"):
            if p.isdigit() and want in _cmdline(p) and _marked(p, mark):
                return int(p)
        raise LookupError(f"no raylet for node {node['NodeID']}")

    def reset_gate(self) -> None:
        self.gate_file.unlink(missing_ok=True)

    def hold(self) -> None:
        """Hold the runs started from now on mid-run (module doc) until ``release()``."""
        self.hold_file.touch()

    def release(self) -> None:
        self.hold_file.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


# -- the gated simulator (runs in the cluster's workers) -----------------------------------------
def _wait_for_gate() -> None:
    gate = os.environ.get("RAP_TEST_GATE_FILE", "")
    nodes = int(os.environ.get("RAP_TEST_GATE_NODES", "0") or 0)
    if not gate or nodes <= 0 or os.path.exists(gate):
        return
    import ray

    deadline = time.monotonic() + 300.0  # a broken cluster: the test then fails on its nodes
    while time.monotonic() < deadline and not os.path.exists(gate):
        alive = sum(1 for n in ray.nodes() if n.get("Alive"))
        if alive >= nodes and ray.available_resources().get("CPU", 0.0) < 1.0:
            Path(gate).touch()
            return
        time.sleep(0.25)


_SIMULATED = [0]  # operations simulated by this worker process


def gated_simulate(assembly, operation, params, rng):
    """``rap.sim.simulator.simulate`` after the cluster-wide gate and the hold, then a pause
    (module doc)."""
    from rap.sim.simulator import simulate

    _wait_for_gate()
    hold = os.environ.get("RAP_TEST_HOLD_FILE", "")
    while _SIMULATED[0] >= HOLD_AFTER and hold and os.path.exists(hold):
        time.sleep(0.25)  # until the test releases the run
    _SIMULATED[0] += 1
    res = simulate(assembly, operation, params, rng)
    time.sleep(float(os.environ.get("RAP_TEST_PAUSE_S", "0") or 0))  # the work's duration
    return res


if __name__ == "__main__":  # ``rap-farm`` with the GATED backend for ``label``
    import rap.farm.driver as driver
    from rap.cli import main

    _run = driver.run_label

    def run_label(cfg, plan=None, **kw):
        return _run(dataclasses.replace(cfg, backend=GATED), plan, **kw)

    driver.run_label = run_label
    main(sys.argv[1:])


@contextlib.contextmanager
def connected(**options):
    """A started ``FakeCluster(**options)`` with this process connected to it (a module fixture's
    body); on exit Ray is shut down, the cluster stopped, and no process of it may survive."""
    import ray

    if ray.is_initialized():
        ray.shutdown()
    c = FakeCluster(**options)
    try:
        c.start()
        c.connect()
        yield c
    finally:
        try:
            ray.shutdown()
        finally:
            c.stop()
    assert not c.leftovers(), "processes of the fake cluster survived its teardown"
