"""The planning service and its page on a 100-part drawing, within a request's budget.

    python benchmarks/service_scale.py [--kind grid|wall] [--budget 120] [--workers 2]
        [--trials 100] [--no-page] [--json out.json]

Starts the real HTTP service (``python -m rap.cli serve`` on a free 127.0.0.1 port, with a token,
a local Ray, ``--workers`` simulation actors and no score-cache file), writes a 100-part drawing
as a user brings one (a DXF written with ezdxf, millimetres, one closed LWPOLYLINE a part: a 10 x 10
grid of 10 mm squares, or a 100-brick running-bond wall, ``benchmarks/plan_scale.py``'s), reads it
through ``POST /import`` as the page does, and plans it through ``POST /plan`` twice: the default
(method search, the request's budget ``--budget``: the service's default unless given) and
simulator-only greedy (method sim). Then it drives the page itself in headless chromium (Debian's,
through Playwright's ``executable_path``; skipped with a line when either is missing): load the
page, type the token, drop the DXF on the file input (the page reads it, inspects it and plans it
with the default method and budget) and wait for the plan shown.

Each plan has its own root seed (11, 12, 13), so none reuses another's simulations from the
service's score cache. Per plan it prints: parts, the request budget, the seconds to the answer
(client side), the status, R, the expected failed steps, the bound and its scope, why the search
stopped (``stats["stopped"]``), and the planning and evaluation seconds the service reports. Times
depend on the machine's load (printed); nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.assembly import Assembly  # noqa: E402

TOKEN = secrets.token_urlsafe(24)
SEEDS = {"default": 11, "greedy": 12, "page": 13}


def drawing_assembly(kind: str) -> Assembly:
    """The 100 parts: a 10 x 10 grid of 10 mm squares, or a 100-brick running-bond wall of 20 x 10
    mm bricks (``benchmarks/plan_scale.py``'s, seed 0)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import plan_scale

    return plan_scale.build(kind, 100, 0)


def write_dxf(assembly: Assembly, path: Path) -> Path:
    """``assembly`` as a user's DXF: one closed LWPOLYLINE a part, on a layer named after it."""
    import ezdxf

    doc = ezdxf.new("R2010", units=4)  # millimetres
    msp = doc.modelspace()
    for part in assembly.parts:
        msp.add_lwpolyline([(float(x), float(y)) for x, y in part.outer], close=True,
                           dxfattribs={"layer": part.id})
    doc.saveas(path)
    return path


def _call(url: str, path: str, body: bytes | None = None, timeout: float = 900):
    headers = {"Content-Type": "application/json", "Authorization": f"Bearer {TOKEN}"}
    req = urllib.request.Request(url + path, data=body, headers=headers,
                                 method="POST" if body is not None else "GET")
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, json.loads(r.read()), dict(r.headers)
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read()), dict(exc.headers)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_service(tmp: Path, workers: int, trials: int) -> tuple[subprocess.Popen, str]:
    """``rap-farm serve`` in its own session on a free loopback port; (process, base URL)."""
    port = _free_port()
    env = dict(os.environ, RAY_AUTH_MODE="token",
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    env.pop("RAP_FARM_TOKEN", None)
    log = open(tmp / "serve.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "rap.cli", "serve", "--host", "127.0.0.1",
                             "--port", str(port), "--token", TOKEN, "--workers", str(workers),
                             "--trials", str(trials), "--no-cache"], cwd=tmp, env=env,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 300
    while True:
        if proc.poll() is not None:
            raise SystemExit(f"rap-farm serve exited {proc.returncode}: "
                             f"{(tmp / 'serve.log').read_text()[-2000:]}")
        try:
            if _call(url, "/health", timeout=5)[0] == 200:
                return proc, url
        except (urllib.error.URLError, OSError, ValueError):
            pass
        if time.monotonic() > deadline:
            stop_service(proc)
            raise SystemExit("rap-farm serve did not become healthy in 300 s")
        time.sleep(1)


def stop_service(proc: subprocess.Popen) -> None:
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=90)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def row(label: str, parts: int, budget: float | None, seconds: float, doc: dict,
        details: dict) -> dict:
    stats = details.get("stats", {})
    bound = doc.get("bound") or {}
    return {"plan": label, "parts": parts, "budget_s": budget, "answer_s": round(seconds, 2),
            "status": doc.get("status", "found" if doc.get("feasible") else doc.get("feasible")),
            "R": doc.get("robustness"), "expected_failures": doc.get("expected_failures"),
            "bound": bound.get("robustness_upper"), "scope": bound.get("scope"),
            "stopped": stats.get("stopped"),
            "plan_s": doc.get("seconds"), "eval_s": details.get("eval_seconds"),
            "bound_s": stats.get("bound_seconds"), "steps": len(doc.get("steps", []))}


def fmt(r: dict) -> str:
    def g(v, spec=".3g"):
        return "-" if v is None else format(v, spec)
    return (f"{r['plan']:<8} parts {r['parts']}  budget {g(r['budget_s'], 'g')} s  answer "
            f"{r['answer_s']:.1f} s  status {r['status']}  R {g(r['R'])}  E[fail] "
            f"{g(r['expected_failures'], '.2f')}  bound {g(r['bound'])} {r['scope'] or ''}  "
            f"stopped {r['stopped'] or '-'}  (plan {g(r['plan_s'], '.1f')} s, eval "
            f"{g(r['eval_s'], '.1f')} s, bound {g(r['bound_s'], '.2f')} s, steps {r['steps']})")


def plan_over_http(url: str, assembly: dict, method: str, seed: int, budget: float | None) -> tuple:
    body = {"assembly": assembly, "method": method, "seed": seed,
            **({} if budget is None else {"budget_s": budget})}
    t = time.perf_counter()
    status, doc, headers = _call(url, "/plan", json.dumps(body).encode())
    seconds = time.perf_counter() - t
    if status != 200:  # a 503: no answer within the budget and its grace
        return seconds, {"status": f"HTTP {status}: {doc.get('error')}"}, {}
    details = json.loads(headers.get("x-plan-details") or headers.get("X-Plan-Details") or "{}")
    return seconds, doc, details


def plan_in_page(url: str, dxf: Path, seed: int, tmp: Path) -> tuple[float, float | None, dict]:
    """Drop ``dxf`` on the page (default method and budget); (seconds measured here, the page's
    own ``data-file-to-plan-s``, the plan it offers for download)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise RuntimeError("Playwright for Python is not installed (pip install -e '.[test]')")
    exe = os.environ.get("RAP_CHROMIUM") or shutil.which("chromium") or shutil.which(
        "chromium-browser")
    if exe is None:
        raise RuntimeError("no chromium on PATH (apt-get install chromium; or set RAP_CHROMIUM)")
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, headless=True)
        try:
            ctx = browser.new_context(viewport={"width": 1280, "height": 900},
                                      accept_downloads=True)
            pg = ctx.new_page()
            pg.goto(url + "/")
            pg.fill("#token", TOKEN)
            pg.press("#token", "Enter")
            pg.wait_for_function("document.getElementById('method').options.length > 0")
            pg.fill("#seed", str(seed))
            t = time.perf_counter()
            pg.set_input_files("#file", str(dxf))
            pg.wait_for_selector("body[data-state=planned], body[data-state=error]",
                                 timeout=900_000)
            seconds = time.perf_counter() - t
            if pg.get_attribute("body", "data-state") != "planned":
                raise RuntimeError(f"the page: {pg.inner_text('#message')}")
            own = pg.get_attribute("body", "data-file-to-plan-s")
            with pg.expect_download() as info:
                pg.click("#dl-json")
            info.value.save_as(tmp / "page-plan.json")
            return seconds, float(own) if own else None, json.loads(
                (tmp / "page-plan.json").read_text())
        finally:
            browser.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kind", choices=("grid", "wall"), default="grid")
    ap.add_argument("--budget", type=float, default=None,
                    help="the requests' budget_s (default: the service's)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--no-page", action="store_true", help="skip the browser")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)

    from rap.serve.api import ServeConfig

    default_budget = ServeConfig.request_budget_s
    budget = args.budget
    shown_budget = budget if budget is not None else default_budget
    print(f"CPUs {os.cpu_count()}, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; "
          f"workers {args.workers}, trials {args.trials}, request budget {shown_budget:g} s")
    rows = []
    with tempfile.TemporaryDirectory(prefix="rap-service-scale-") as d:
        tmp = Path(d)
        asm = drawing_assembly(args.kind)
        dxf = write_dxf(asm, tmp / f"{args.kind}100.dxf")
        t = time.perf_counter()
        proc, url = start_service(tmp, args.workers, args.trials)
        print(f"service healthy at {url} in {time.perf_counter() - t:.1f} s")
        try:
            status, imported, _ = _call(url, f"/import?name={dxf.name}", dxf.read_bytes())
            if status != 200:
                raise SystemExit(f"POST /import: {status} {imported}")
            parts = len(imported["parts"])
            print(f"{dxf.name}: {parts} parts, {dxf.stat().st_size} bytes")
            for label, method in (("default", "search"), ("greedy", "sim")):
                seconds, doc, details = plan_over_http(url, imported, method, SEEDS[label],
                                                       budget)
                rows.append(row(label, parts, shown_budget, seconds, doc, details))
                print(fmt(rows[-1]), flush=True)
            if not args.no_page:
                try:
                    seconds, own, doc = plan_in_page(url, dxf, SEEDS["page"], tmp)
                except RuntimeError as exc:
                    print(f"page: skipped ({exc})")
                else:
                    rows.append(row("page", parts, default_budget, seconds, doc, {}))
                    print(fmt(rows[-1]))
                    print(f"page: {seconds:.1f} s from the file dropped to the plan shown "
                          f"(the page's own count: {own if own is None else round(own, 1)} s)")
        finally:
            stop_service(proc)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
