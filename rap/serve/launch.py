"""Running the planning service: start or join Ray, deploy ``rap.serve.http_app``'s application on
Ray Serve, wait until it is healthy, and serve until interrupted (``rap-farm serve``)."""

import json
import logging
import os
import signal
import socket
import threading
import time
import urllib.error
import urllib.request
from typing import Callable

from ray import serve

from rap.errors import InputError

from rap.serve.api import ServeConfig
from rap.serve.http_app import APP_NAME, build_app

__all__ = ["run_service", "wait_healthy"]


def _port_free(host: str, port: int) -> bool:
    family = socket.AF_INET6 if ":" in host.strip("[]") else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host.strip("[]"), port))
        except OSError:
            return False
    return True


def _url(host: str, port: int) -> str:
    h = "127.0.0.1" if host in ("0.0.0.0", "") else ("[::1]" if host == "::" else host)
    if ":" in h and not h.startswith("["):
        h = f"[{h}]"
    return f"http://{h}:{port}"


def wait_healthy(url: str, token: str | None, timeout_s: float) -> dict:
    """Poll ``url``/health until it answers 200; its JSON. ``TimeoutError`` otherwise."""
    deadline = time.monotonic() + timeout_s
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    last = "no answer"
    while time.monotonic() < deadline:
        try:
            req = urllib.request.Request(url + "/health", headers=headers)
            with urllib.request.urlopen(req, timeout=10) as resp:
                return json.loads(resp.read())
        except urllib.error.HTTPError as exc:
            last = f"HTTP {exc.code}"
        except (urllib.error.URLError, OSError, ValueError) as exc:
            last = str(getattr(exc, "reason", exc))
        time.sleep(0.5)
    raise TimeoutError(f"the service did not become healthy in {timeout_s:.0f} s ({last})")


def run_service(config: ServeConfig, *, address: str | None = None,
                echo: Callable[[str], None] = print, ready_timeout_s: float = 600.0,
                stop: threading.Event | None = None) -> None:
    """Start (or join) Ray, deploy the service, print where it listens and serve until SIGINT or
    SIGTERM (or ``stop`` is set); then remove it, which stops taking requests and gives those in
    flight ``rap.serve.http_app.STOP_GRACE_S`` (30 s) to finish (and stop the embedded Ray, if
    started here)."""
    from rap.farm.runtime import connect

    config.check()
    if address is None and not os.environ.get("RAY_ADDRESS") and not _port_free(config.host,
                                                                                 config.port):
        raise InputError(f"--port {config.port}: {config.host}:{config.port} is already in use")
    logging.getLogger("ray.serve").setLevel(logging.WARNING)  # our own line says where it runs
    stop = stop or threading.Event()
    previous = {}

    def listen() -> None:  # again after Serve has started: Ray's own SIGTERM handler is off
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                old = signal.signal(sig, lambda *_: stop.set())
                previous.setdefault(sig, old)

    listen()
    try:
        with connect(address) as rt:
            quiet = {"log_level": "WARNING", "enable_access_log": False}
            try:
                serve.start(proxy_location="HeadOnly", logging_config=quiet,
                            http_options={"host": config.host, "port": config.port})
                serve.run(build_app(config), name=APP_NAME, route_prefix="/", blocking=False,
                          logging_config=quiet)
                listen()
            except Exception as exc:
                first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise InputError(f"cannot start the planning service: {first[:300]}") from None
            try:
                url = _url(config.host, config.port)
                if not rt.started_here:  # the proxy runs on the cluster's head node
                    health = None
                else:
                    health = wait_healthy(url, config.token, ready_timeout_s)
                where = url if rt.started_here else f"port {config.port} of the cluster's head node"
                echo(f"rap-farm planning service on {where} (docs: /docs)"
                     + (f"; {health['workers']} simulation workers" if health else "")
                     + "; Ctrl-C stops it")
                while not stop.wait(1.0):
                    pass
                echo("stopping the planning service ...")
            finally:
                try:  # the application only: an embedded Ray takes Serve's actors with it, and
                    # serve.shutdown() would print Ray's "(raylet) Task ServeController.
                    # graceful_shutdown failed ..." on the user's console
                    serve.delete(APP_NAME)
                except Exception:
                    pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
