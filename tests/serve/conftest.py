"""The planning service's tests share the farm's fixtures (a local Ray, its environment) and one
running ``rap-farm serve`` (fixture ``service``)."""

from __future__ import annotations

import http.client
import os
import signal
import subprocess
import sys
import time
import urllib.error
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.farm.conftest import ray_env, ray_local  # noqa: F401  (ray_local: a fixture, by name)
from tests.ports import free_port
from tests.shared_resources import shared


@dataclass
class Service:
    url: str
    proc: subprocess.Popen
    log_path: Path
    log: object


def _start_service(tmp: Path) -> Service:
    from tests.serve.test_http_app import TOKEN, TRIALS, _call

    port = free_port()
    env = dict(ray_env(), RAP_CACHE=str(tmp / "cache.json"))
    env.pop("RAP_FARM_TOKEN", None)
    log = open(tmp / "serve.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "rap.cli", "serve", "--port", str(port),
                             "--trials", str(TRIALS), "--token", TOKEN, "--workers", "2"],
                            cwd=tmp, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    svc = Service(f"http://127.0.0.1:{port}", proc, tmp / "serve.log", log)
    try:
        deadline = time.monotonic() + 150
        while True:
            if proc.poll() is not None:
                pytest.fail(f"rap-farm serve exited {proc.returncode}: "
                            f"{svc.log_path.read_text()[-2000:]}")
            try:
                if _call(svc.url, "/health", timeout=5)[0] == 200:
                    return svc
            except (urllib.error.URLError, OSError, ValueError, http.client.HTTPException):
                pass
            if time.monotonic() > deadline:
                pytest.fail("rap-farm serve did not become healthy in 150 s")
            time.sleep(1)  # polls /health
    except BaseException:
        _stop(svc)
        raise


def _stop(svc: Service) -> None:
    """SIGINT (Ctrl-C), as a user stops it; SIGKILL to the group if it has not ended in 60 s."""
    proc = svc.proc
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    svc.log.close()


def _stop_service(svc: Service) -> None:
    _stop(svc)
    text = svc.log_path.read_text()
    assert svc.proc.returncode == 0, text[-2000:]
    # Serve's shutdown noise ("(raylet) Task ServeController.graceful_shutdown failed ...") stays
    # off the console: the last line is the service's own
    assert "(raylet)" not in text and text.endswith("stopping the planning service ...\n"), text


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    """``rap-farm serve`` on a free loopback port with a token (``TOKEN``, ``TRIALS`` of
    tests/serve/test_http_app.py); its base URL. One service for the consecutive modules that use
    it (test_http_app.py, then test_page.py): started by the first, stopped after the last
    (tests/shared_resources.py), and then required to have exited 0 with its own last line."""
    svc = shared("service", lambda: _start_service(tmp_path_factory.mktemp("serve")),
                 _stop_service, alive=lambda s: s.proc.poll() is None)
    return svc.url
