"""Load test of the planning service (``rap-farm serve``) over loopback.

Starts ``rap-farm serve`` on a free loopback port (or uses ``--url``), plans each assembly once
(warm-up: loads the replica's caches), then for each phase runs ``--clients`` concurrent clients
for ``--seconds`` and prints requests per second, p50 and p95 latency and errors:

* ``cached``: the same requests again (the score cache holds every evaluation): the CNN, the NDBG
  and HTTP, what a cell asking for the same plans again sees;
* ``fresh``: a new root seed per request, so every step of every returned sequence is simulated
  (``--trials`` each) on the service's pool.

Then a burst of ``--burst`` malformed or invalid requests from the same clients (bad JSON, unknown
keys and methods, invalid geometry, oversized bodies, missing token), counted by status, and a
final check that the service still answers: ``/health`` and a plan equal to the warm-up plan.

    python benchmarks/serve.py [--clients 8] [--seconds 30] [--trials 100] [--burst 400]
                               [--assemblies hexagon,rectilinear,triangles] [--url URL --token T]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import secrets
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def post(url: str, body: bytes, token: str | None, timeout: float = 600) -> tuple[int, bytes]:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(url + "/plan", data=body, headers=headers, method="POST")
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()
    except (urllib.error.URLError, OSError) as exc:
        return -1, str(exc).encode()


def body(assembly: dict, method: str, seed: int) -> bytes:
    return json.dumps({"assembly": assembly, "method": method, "seed": seed}).encode()


def start_service(trials: int, token: str, workers: int | None) -> tuple[subprocess.Popen, str]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    args = [sys.executable, "-m", "rap.cli", "serve", "--port", str(port), "--trials", str(trials),
            "--token", token, "--no-cache"] + (["--workers", str(workers)] if workers else [])
    log = tempfile.TemporaryFile()
    proc = subprocess.Popen(args, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    t = time.perf_counter()
    while time.perf_counter() - t < 300:
        if proc.poll() is not None:
            log.seek(0)
            sys.exit(f"rap-farm serve exited {proc.returncode}:\n{log.read().decode()[-3000:]}")
        try:
            req = urllib.request.Request(url + "/health", headers={"Authorization": f"Bearer {token}"})
            with urllib.request.urlopen(req, timeout=5) as r:
                if r.status == 200:
                    print(f"service healthy after {time.perf_counter() - t:.1f} s "
                          f"(start-up: Ray, Serve, model, {json.loads(r.read())['workers']} workers)")
                    return proc, url
        except (urllib.error.URLError, OSError):
            pass
        time.sleep(0.5)
    proc.kill()
    sys.exit("rap-farm serve did not become healthy in 300 s")


def load_phase(label: str, url: str, token: str | None, clients: int, seconds: float,
               make_body) -> None:
    stop = time.monotonic() + seconds
    lat: list[float] = []
    codes: dict[int, int] = {}
    lock = threading.Lock()
    counter = itertools.count()

    def client(_):
        while time.monotonic() < stop:
            b = make_body(next(counter))
            t = time.perf_counter()
            code, _ = post(url, b, token)
            dt = time.perf_counter() - t
            with lock:
                codes[code] = codes.get(code, 0) + 1
                if code == 200:
                    lat.append(dt)

    t0 = time.perf_counter()
    with ThreadPoolExecutor(clients) as ex:
        list(ex.map(client, range(clients)))
    wall = time.perf_counter() - t0
    n = sum(codes.values())
    errors = n - codes.get(200, 0)
    if lat:
        q = statistics.quantiles(lat, n=20) if len(lat) > 1 else [lat[0]] * 19
        print(f"  {label:7s} {clients} clients, {wall:5.1f} s: {len(lat)} plans, "
              f"{len(lat) / wall:6.2f} req/s, p50 {statistics.median(lat) * 1000:7.0f} ms, "
              f"p95 {q[18] * 1000:7.0f} ms, errors {errors}")
    else:
        print(f"  {label:7s} no successful request; statuses {codes}")


def bad_bodies(good: dict) -> list[tuple[bytes, str | None]]:
    parts = good["parts"]
    overlap = {"parts": [{"id": "a", "polygon": [[0, 0], [2, 0], [2, 2], [0, 2]]},
                         {"id": "b", "polygon": [[1, 1], [3, 1], [3, 3], [1, 3]]}]}
    return [
        (b"{\"assembly\": ", "t"), (b"", "t"), (b"[]", "t"), (b"{\"method\": \"rap\"}", "t"),
        (json.dumps({"assembly": good, "methd": "rap"}).encode(), "t"),
        (json.dumps({"assembly": good, "method": "best"}).encode(), "t"),
        (json.dumps({"assembly": good, "seed": "x"}).encode(), "t"),
        (json.dumps({"assembly": overlap}).encode(), "t"),
        (json.dumps({"assembly": {"parts": parts[:1] + [{"id": parts[0]["id"],
                                                          "polygon": [[0, 0]]}]}}).encode(), "t"),
        (b"{\"assembly\": " + b"[" * 50000 + b"]" * 50000 + b"}", "t"),
        (b"{\"assembly\": \"" + b"x" * (2 << 20) + b"\"}", "t"),
        (json.dumps({"assembly": good}).encode(), None),  # no token
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--burst", type=int, default=400)
    ap.add_argument("--method", default="rap")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--assemblies", default="hexagon,rectilinear,triangles")
    ap.add_argument("--url", default=None, help="use a running service instead of starting one")
    ap.add_argument("--token", default=None)
    a = ap.parse_args()

    docs = [json.loads((ROOT / "assemblies" / f"{n}.json").read_text())
            for n in a.assemblies.split(",")]
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; method {a.method}, "
          f"assemblies {a.assemblies}, {a.trials} trials per simulation")
    proc = None
    if a.url:
        url, token = a.url.rstrip("/"), a.token or os.environ.get("RAP_FARM_TOKEN")
    else:
        token = secrets.token_urlsafe(24)
        proc, url = start_service(a.trials, token, a.workers)
    try:
        t = time.perf_counter()
        reference = {}
        for d in docs:
            code, raw = post(url, body(d, a.method, 1), token)
            if code != 200:
                sys.exit(f"warm-up request failed: {code} {raw[:300]!r}")
            reference[d.get("name")] = json.loads(raw)
        print(f"warm-up: {len(docs)} plans in {time.perf_counter() - t:.1f} s")
        load_phase("cached", url, token, a.clients, a.seconds,
                   lambda i: body(docs[i % len(docs)], a.method, 1))
        load_phase("fresh", url, token, a.clients, a.seconds,
                   lambda i: body(docs[i % len(docs)], a.method, 1000 + i))

        bad = bad_bodies(docs[0])
        codes: dict[int, int] = {}
        lock = threading.Lock()

        def send(i):
            b, tok = bad[i % len(bad)]
            code, raw = post(url, b, token if tok else None, timeout=60)
            one_line = code >= 400 and "\n" not in json.loads(raw).get("error", "\n")
            with lock:
                key = code if one_line else -code
                codes[key] = codes.get(key, 0) + 1

        t = time.perf_counter()
        with ThreadPoolExecutor(a.clients) as ex:
            list(ex.map(send, range(a.burst)))
        dt = time.perf_counter() - t
        print(f"  burst   {a.burst} malformed requests in {dt:.1f} s: statuses "
              + ", ".join(f"{k}: {v}" for k, v in sorted(codes.items()))
              + " (negative: not a one-line JSON error)")

        req = urllib.request.Request(url + "/health", headers={"Authorization": f"Bearer {token}"})
        with urllib.request.urlopen(req, timeout=30) as r:
            health = json.loads(r.read())
        same = all(json.loads(post(url, body(d, a.method, 1), token)[1]).get("steps")
                   == reference[d.get("name")]["steps"] for d in docs)
        print(f"after the burst: health {health['status']}, {health['served']} plans served, "
              f"peak {health['peak_concurrent']} requests planned at once; the warm-up plans "
              f"again: {'identical' if same else 'DIFFERENT'}")
    finally:
        if proc is not None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)


if __name__ == "__main__":
    main()
