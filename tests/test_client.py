"""rap.client against a stand-in HTTP server (no Ray, no service): its errors name the parameter
``server``; ``rap-farm plan --server`` shows the same lines with the flag."""

from __future__ import annotations

import json
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from rap.client import ServiceError, post_plan
from rap.errors import ParameterError

HEXAGON = str(Path(__file__).resolve().parents[1] / "assemblies" / "hexagon.json")


class _Answer(BaseHTTPRequestHandler):
    answer = (500, b"")  # (status, body) of every POST

    def do_POST(self):  # noqa: N802 (http.server's name)
        self.rfile.read(int(self.headers.get("Content-Length", 0)))
        status, body = self.answer
        self.send_response(status)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def stand_in():
    """``answer(status, body)`` -> the URL of a server that answers every POST so."""
    servers = []

    def answer(status: int, body: bytes) -> str:
        handler = type("Handler", (_Answer,), {"answer": (status, body)})
        server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}"

    yield answer
    for server in servers:
        server.shutdown()
        server.server_close()


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


ERROR = json.dumps({"error": "options.optimism 2: choose a number in [0, 1]"}).encode()
CASES = [  # (status, body) answered, the error, the reason
    ((401, json.dumps({"error": "missing bearer token"}).encode()), ParameterError,
     "not authorised (missing bearer token); pass a token or set RAP_FARM_TOKEN"),
    ((400, ERROR), ParameterError, "options.optimism 2: choose a number in [0, 1]"),
    ((500, b"boom\ntraceback"), ServiceError, "the service failed (HTTP 500): boom"),
    ((200, b"<html>"), ServiceError, "the answer is not JSON"),
    ((200, b"[1, 2]"), ServiceError, "the answer is not a plan document"),
]


@pytest.mark.parametrize("answer, error, reason", CASES)
def test_errors_name_the_parameter_server(stand_in, answer, error, reason):
    url = stand_in(*answer)
    with pytest.raises(error) as err:
        post_plan(url, b"{}", timeout_s=30)
    assert str(err.value) == f"server {url}: {reason}"
    assert isinstance(err.value, ServiceError) or err.value.parameter == "server"


def test_a_wrong_or_unreachable_address_names_the_parameter_server():
    with pytest.raises(ParameterError) as err:
        post_plan("ftp://host:21", b"{}")
    assert str(err.value) == "server ftp://host:21: expected http://HOST:PORT or https://HOST:PORT"
    url = f"http://127.0.0.1:{_closed_port()}"
    with pytest.raises(ParameterError) as err:
        post_plan(url, b"{}", timeout_s=30)
    assert err.value.parameter == "server"
    assert str(err.value).startswith(f"server {url}: cannot reach the planning service (")


@pytest.mark.parametrize("answer, status, reason", [
    ((401, json.dumps({"error": "missing bearer token"}).encode()), 2,
     "not authorised (missing bearer token); pass a token or set RAP_FARM_TOKEN"),
    ((400, ERROR), 2, "options.optimism 2: choose a number in [0, 1]"),
    ((500, b"boom"), 3, "the service failed (HTTP 500): boom"),
    ((200, b"{}"), 3, None),  # a document PlanResult cannot read: the client takes it, plan not
])
def test_plan_server_names_the_flag(stand_in, run_cli, monkeypatch, answer, status, reason):
    monkeypatch.delenv("RAP_FARM_TOKEN", raising=False)
    url = stand_in(*answer)
    code, _, err = run_cli("plan", HEXAGON, "--server", url)
    assert code == status
    if reason is None:
        assert err.startswith(f"rap-farm: error: --server {url}: ") and err.count("\n") == 1
    else:
        assert err == f"rap-farm: error: --server {url}: {reason}\n"


def test_plan_server_with_a_wrong_address_names_the_flag(run_cli):
    code, _, err = run_cli("plan", HEXAGON, "--server", "ftp://host:21")
    assert code == 2
    assert err == ("rap-farm: error: --server ftp://host:21: expected http://HOST:PORT or "
                   "https://HOST:PORT\n")
