"""From a file to a plan shown in the planning page, in a real headless browser.

Starts ``rap-farm serve`` on a free loopback port (or uses ``--url``), warms it with one plan
over the JSON API (model loaded, simulation workers started and compiled), then opens the page
at ``/`` in Debian's chromium (Playwright) and, ``--runs`` times per file, uploads the file and
waits until the storyboard is shown. Each run has a fresh seed, so every step of the returned
plan is simulated (``--trials`` each); then one run repeats the first seed (scores cached).
Printed per file: the seconds from choosing the file to the plan shown, as the page measures
them (``performance.now()``: reading and NDBG on the service, drawing, planning, storyboard)
and as the driver sees them (upload to the page's "planned" state), median, min and max.

The files: ``--files`` (default: the 7-part tangram, ``assemblies/unseen/tangram.json``, and,
when ``rap.cad`` is present, two 7-part DXF drawings with arcs written with ezdxf: ``seven.dxf``
of tests/cad/fixtures.py, blocks with arc joints in a tray, a cap and two discs, and ``pegs.dxf``
of tests/serve/test_page.py, round-ended pegs in round notches under notched caps).

    python benchmarks/page.py [--runs 5] [--method search] [--trials 100] [--workers N]
                              [--files a.json,b.dxf] [--url URL --token T]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import secrets
import signal
import statistics
import sys
import tempfile
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from serve import body, post, start_service  # noqa: E402  (benchmarks/serve.py)
from tests.serve.test_page import chromium_path, open_page, plan_file, seven_part_dxf  # noqa: E402


def _files(arg: str | None, tmp: Path) -> list[Path]:
    if arg:
        return [Path(f) for f in arg.split(",")]
    files = [ROOT / "assemblies" / "unseen" / "tangram.json"]
    if importlib.util.find_spec("rap.cad") is not None:
        from tests.cad.fixtures import dxf_seven

        files += [dxf_seven(tmp), seven_part_dxf(tmp / "pegs.dxf")]
    return files


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--method", default="search")
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--files", default=None)
    ap.add_argument("--url", default=None)
    ap.add_argument("--token", default=None)
    a = ap.parse_args()
    exe = chromium_path()
    if exe is None:
        sys.exit("no chromium on PATH: apt-get install chromium")
    from playwright.sync_api import sync_playwright

    proc = None
    token = a.token or secrets.token_urlsafe(24)
    try:
        if a.url:
            url = a.url.rstrip("/")
        else:
            proc, url = start_service(a.trials, token, a.workers)
        hexagon = json.loads((ROOT / "assemblies" / "hexagon.json").read_text())
        code, _ = post(url, body(hexagon, a.method, 1), token)  # warm-up over the JSON API
        if code != 200:
            sys.exit(f"warm-up plan: HTTP {code}")
        req = urllib.request.Request(url + "/health", headers={"Authorization": f"Bearer {token}"})
        with urllib.request.urlopen(req, timeout=30) as r:
            health = json.loads(r.read())
        print(f"service warm: {health['workers']} simulation workers, {health['trials']} trials "
              f"per score, {os.cpu_count()} CPUs on this machine; method {a.method}")
        with tempfile.TemporaryDirectory() as tmp, sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=exe, headless=True)
            pg = browser.new_page(viewport={"width": 1280, "height": 900})
            open_page(pg, url, token)
            print(f"{'file':<16} {'runs':>4}  {'page median':>11} {'min':>6} {'max':>6}  "
                  f"{'driver median':>13}  {'cached':>6}")
            for path in _files(a.files, Path(tmp)):
                page_s, driver_s = [], []
                for run in range(a.runs):
                    driver_s.append(plan_file(pg, path, a.method, 7000 + run))
                    page_s.append(float(pg.get_attribute("body", "data-file-to-plan-s")))
                plan_file(pg, path, a.method, 7000)
                cached = float(pg.get_attribute("body", "data-file-to-plan-s"))
                print(f"{path.name:<16} {a.runs:>4}  {statistics.median(page_s):>10.2f}s "
                      f"{min(page_s):>5.2f}s {max(page_s):>5.2f}s  "
                      f"{statistics.median(driver_s):>12.2f}s  {cached:>5.2f}s")
            browser.close()
    finally:
        if proc is not None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=60)
            except Exception:
                os.killpg(proc.pid, signal.SIGKILL)


if __name__ == "__main__":
    main()
