"""Starting or joining Ray: the one place where the farm decides which cluster it runs on.

``connect(address=None)``:

* no address and no ``RAY_ADDRESS`` in the environment -> start an embedded local Ray on this machine
  with all its cores (or ``num_cpus``); it is shut down when the context exits;
* ``address="auto"`` or ``"HOST:PORT"`` (or ``RAY_ADDRESS``) -> join that existing cluster; the
  cluster is left running when the context exits.

Ray 2.60 turns token authentication on by default for a cluster started by ``ray.init()`` (a token
is created in ``~/.ray/auth_token`` unless ``RAY_AUTH_TOKEN`` / ``RAY_AUTH_TOKEN_PATH`` supply
one). Joining a cluster that runs with ``RAY_AUTH_MODE=token`` needs the same token here; we never
switch authentication off (docs/CLUSTER.md).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import threading
from dataclasses import dataclass
from typing import Iterator

import ray

from rap.errors import InputError

__all__ = ["RayRuntime", "connect", "init_ray", "node_label", "cluster_cpus", "nodes_now", "node_churn"]

# Ray's notice, at every local start, that it turned token authentication on by default stays off
# the user's console (the module doc and docs/CLUSTER.md say so); its other warnings stay.
logging.getLogger("ray._private.authentication.authentication_token_setup").addFilter(
    lambda record: not record.getMessage().startswith("Token authentication is enabled for this"))


@dataclass(frozen=True)
class RayRuntime:
    """What ``connect`` started or joined."""

    address: str | None  # None: an embedded local Ray started by us
    started_here: bool  # True: an embedded Ray that goes away with the context
    cpus: int  # CPUs in the whole cluster
    nodes: int  # alive nodes


def cluster_cpus() -> int:
    """CPUs across the alive nodes of the connected cluster (at least 1)."""
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


def nodes_now() -> dict[str, bool]:
    """Every node the cluster's GCS knows, dead ones included: node id -> alive ({} when the GCS
    does not answer)."""
    try:
        return {n["NodeID"]: bool(n.get("Alive")) for n in ray.nodes()}
    except Exception:
        return {}


def node_churn(before: dict[str, bool], after: dict[str, bool]) -> tuple[int, int]:
    """``(joined, left)`` between two ``nodes_now()``: nodes unknown before, and nodes alive before
    (or joined since) that are dead now. The GCS keeps the last 1,000 dead nodes by default."""
    joined = sum(1 for n in after if n not in before)
    left = sum(1 for n, alive in after.items() if not alive and before.get(n, True))
    return joined, left


def node_label() -> str:
    """Which node this process runs on: ``hostname/<Ray node id>``, the whole hex id, which is
    unique per node of a cluster (a prefix is not: Ray's fake multi-node provider, for one, numbers
    its nodes in the last digits, ``fff...f00001``), also for several nodes on one machine."""
    try:
        nid = ray.get_runtime_context().get_node_id() or ""
    except Exception:  # not inside Ray
        nid = ""
    host = socket.gethostname()
    return f"{host}/{nid}" if nid else host


def init_ray(**kwargs) -> None:
    """``ray.init(**kwargs)``, keeping the SIGTERM handler this process chose. ``ray.init``
    replaces it with its own (``sys.exit(15)``: a command stopped by SIGTERM would exit 15, not
    130, past our cleanup) and Ray's core worker adds a handler that prints a C++ stack dump
    ("*** SIGTERM received at time=..."); a Python handler set before (the CLI's: SIGTERM as
    Ctrl-C) is put back. Without one, Ray's handlers stay."""
    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    try:
        ray.init(**kwargs)
    finally:
        if callable(before):
            signal.signal(signal.SIGTERM, before)


@contextlib.contextmanager
def connect(address: str | None = None, num_cpus: int | None = None,
            log_to_driver: bool = False) -> Iterator[RayRuntime]:
    """Start an embedded Ray or join a cluster for the duration of the ``with`` block.

    If Ray is already initialised in this process (a test, a notebook, a Ray Job), that session is
    used and left alone. Errors reaching a cluster raise ``InputError`` (one line).
    """
    if ray.is_initialized():
        yield RayRuntime(address=address, started_here=False, cpus=cluster_cpus(),
                         nodes=sum(1 for n in ray.nodes() if n.get("Alive")))
        return
    address = address or os.environ.get("RAY_ADDRESS") or None
    kwargs = dict(log_to_driver=log_to_driver, configure_logging=True, logging_level="WARNING")
    try:
        if address:
            init_ray(address=address, **kwargs)
        else:
            init_ray(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False, **kwargs)
    except (ConnectionError, ValueError, RuntimeError, TimeoutError) as exc:
        where = address or "a local Ray instance"
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        hint = (" (is the address right, and does RAY_AUTH_TOKEN or ~/.ray/auth_token hold the "
                "cluster's token?)") if address else ""
        raise InputError(f"cannot start or reach {where}: {msg}{hint}") from None
    except Exception as exc:  # ray.exceptions.AuthenticationError and friends
        if type(exc).__module__.startswith("ray"):
            msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(f"cannot connect to {address or 'local Ray'}: {msg}") from None
        raise
    try:
        yield RayRuntime(address=address, started_here=not address, cpus=cluster_cpus(),
                         nodes=sum(1 for n in ray.nodes() if n.get("Alive")))
    finally:
        ray.shutdown()
