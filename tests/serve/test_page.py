"""The planning page at ``/`` of ``rap-farm serve`` in a real headless browser, and the endpoints
behind it (``POST /import``, ``POST /inspect``, ``POST /export``), and ``/docs`` offline.

The service is the one test_http_app.py uses (tests/serve/conftest.py: a subprocess on a free
loopback port, with a token); the browser is Debian's ``chromium`` driven by Playwright
(``executable_path``: Playwright's own browser download does not work offline). Every request the
browser makes to another host than the service is refused and recorded, and none may be made.
Where Playwright or chromium is missing the browser tests skip and say so (``apt-get install
chromium``, ``pip install -e .[test]``).

Screenshots are test artefacts under tmp_path; ``RAP_PAGE_SCREENSHOT=docs/planning-page.png``
writes the README's screenshot too.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import time
import urllib.request
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from rap.assembly import assembly_to_json
from rap.io import load_assembly
from rap.plan.report.result import PlanResult, PlanStep
from rap.plan.report.validate import check_plan

from tests.farm.conftest import ASSEMBLIES, ROOT
from tests.serve.test_http_app import DOVETAIL, TOKEN, _body, _call, _same_plan

pytestmark = [pytest.mark.ray, pytest.mark.slow]

TANGRAM = ASSEMBLIES / "unseen" / "tangram.json"
SVG_NAMESPACES = {"http://www.w3.org/2000/svg"}  # XML namespace names: identifiers, never fetched
URL = re.compile(r"""https?://[^\s"'`<>)]+""")
WAIT_MS = 240_000  # the harness's bound on a plan shown in the page


def chromium_path() -> str | None:
    """Debian's chromium (or ``RAP_CHROMIUM``), for Playwright's ``executable_path``."""
    return os.environ.get("RAP_CHROMIUM") or shutil.which("chromium") or shutil.which(
        "chromium-browser")


@pytest.fixture(scope="module")
def browser():
    """Headless chromium through Playwright, or a skip that says what is missing."""
    if importlib.util.find_spec("playwright") is None:
        pytest.skip("Playwright for Python is not installed (pip install -e '.[test]')")
    exe = chromium_path()
    if exe is None:
        pytest.skip("no chromium on PATH (apt-get install chromium; or set RAP_CHROMIUM)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=exe, headless=True)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture
def page(browser, service):
    """A fresh page (fresh sessionStorage) whose requests to any other host are refused; the
    refused URLs are in ``page.foreign`` and page errors in ``page.errors``."""
    context = browser.new_context(viewport={"width": 1280, "height": 900}, accept_downloads=True)
    pg = context.new_page()
    pg.foreign, pg.errors = [], []

    def only_the_service(route):
        if route.request.url.startswith(service + "/"):
            route.continue_()
        else:
            pg.foreign.append(route.request.url)
            route.abort()

    pg.route("**/*", only_the_service)
    pg.on("pageerror", lambda exc: pg.errors.append(str(exc)))
    try:
        yield pg
    finally:
        context.close()
    assert pg.foreign == [], f"the page asked other hosts: {pg.foreign}"
    assert pg.errors == [], pg.errors


def _get(url: str) -> str:
    with urllib.request.urlopen(url, timeout=30) as r:
        assert r.status == 200
        return r.read().decode()


def _upload(url: str, path: str, data: bytes, token: str | None = TOKEN):
    return _call(url, path, data, token=token, method="POST")


# -- the endpoints --------------------------------------------------------------------------------

def test_import_and_inspect_read_an_assembly_file_as_the_cli_does(service):
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.partitions import cell_partition_counts

    asm = load_assembly(TANGRAM)
    status, doc, _ = _upload(service, "/import?name=tangram.json", TANGRAM.read_bytes())
    assert status == 200, doc
    assert doc == json.loads(json.dumps(assembly_to_json(asm)))
    status, doc, _ = _upload(service, "/inspect?name=tangram.json", TANGRAM.read_bytes())
    assert status == 200, doc
    ndbg = build_ndbg(asm)
    assert doc["assembly"] == json.loads(json.dumps(assembly_to_json(asm)))
    assert [c["kind"] for c in doc["cells"]] == [c.kind for c in ndbg.cells]
    assert [c["direction"] for c in doc["cells"]] == [list(c.unit) for c in ndbg.cells]
    assert [c["partitions"] for c in doc["cells"]] == cell_partition_counts(ndbg,
                                                                             frozenset(asm.ids))
    unnamed = json.loads(TANGRAM.read_text())
    unnamed.pop("name")  # an assembly without a name is called after the uploaded file
    status, doc, _ = _upload(service, "/import?name=my%20tangram.json", json.dumps(unnamed).encode())
    assert status == 200 and doc["name"] == "my tangram"


def test_import_reads_an_svg_drawing(service):
    if importlib.util.find_spec("rap.cad") is None:
        pytest.skip("rap.cad (the DXF/SVG importer of issue 29) is not in this checkout yet")
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="10mm" '
           'viewBox="0 0 20 10"><rect id="left" x="0" y="0" width="10" height="10"/>'
           '<rect id="right" x="10" y="0" width="10" height="10"/></svg>')
    status, doc, _ = _upload(service, "/import?name=two.svg", svg.encode())
    assert status == 200, doc
    assert doc["name"] == "two" and len(doc["parts"]) == 2
    # no physical size: a user unit is a CSS px (1/96 in), as the CLI reads it
    status, doc, _ = _upload(service, "/import?name=bare.svg", svg.replace('width="20mm" '
                             'height="10mm" ', "").encode())
    assert status == 200 and len(doc["parts"]) == 2, doc
    assert max(float(x) for p in doc["parts"] for x, _ in p["polygon"]) == \
        pytest.approx(20 * 25.4 / 96, abs=0.01)
    # overlapping parts: a 400 naming the overlap
    status, doc, _ = _upload(service, "/import?name=over.svg", svg.replace('x="10"', 'x="5"')
                             .encode())
    assert status == 400 and doc["error"].startswith("over.svg: ") and "overlap" in doc["error"]


BAD_UPLOADS = [
    ("no name", "/import", b"{}", 400, "no name"),
    ("unknown suffix", "/import?name=part.txt", b"{}", 400, "ending in .dxf, .svg, .json"),
    ("not json", "/inspect?name=tangram.json", b"{\"parts\": [", 400, "tangram.json: not valid JSON"),
    ("binary", "/import?name=a.json", b"\x89PNG\r\n\x1a\n0000", 400, "a.json: is a PNG image"),
    ("invalid part", "/inspect?name=../../x.json",
     json.dumps({"parts": [{"id": "a", "polygon": [[0, 0], [1, 0]]}]}).encode(), 400,
     "x.json: part 'a'"),
    ("too many parts", "/import?name=many.json",
     json.dumps({"parts": [{"id": f"p{i}", "polygon": [[i, 0], [i + 1, 0], [i, 1]]}
                           for i in range(1001)]}).encode(), 400,  # past the input bounds
     "many.json: 1001 parts; at most 1000 are read"),
    ("too large", "/inspect?name=big.json", b" " * (2 << 20), 413, "request body over"),
]


@pytest.mark.parametrize("name,path,data,status,needle", BAD_UPLOADS, ids=[c[0] for c in BAD_UPLOADS])
def test_bad_uploads_get_4xx_and_one_line_naming_the_file(service, name, path, data, status,
                                                           needle):
    got, doc, _ = _upload(service, path, data)
    assert got == status, doc
    assert list(doc) == ["error"] and "\n" not in doc["error"] and needle in doc["error"], doc
    assert "rap-upload-" not in doc["error"]  # the temporary path never shows


def test_uploads_need_the_token_and_the_page_does_not(service):
    for path in ("/import?name=t.json", "/inspect?name=t.json"):
        assert _upload(service, path, TANGRAM.read_bytes(), token=None)[0] == 401
        assert _upload(service, path, TANGRAM.read_bytes(), token="x" * 32)[0] == 401
    for path in ("/", "/static/app.js", "/static/app.css", "/docs", "/openapi.json"):
        _get(service + path)  # 200 without a token, as the documentation always was
    spec = json.loads(_get(service + "/openapi.json"))
    assert {"/plan", "/health", "/import", "/inspect"} <= set(spec["paths"])


def test_the_examples_are_public_and_only_the_shipped_ones(service):
    """GET /examples and /examples/NAME answer without a token (the package's own data, as the
    page); any other name is a 404 and one line."""
    from rap.serve.examples import EXAMPLES_DIR, example_list

    assert _call(service, "/examples", token=None)[:2] == (200, example_list())
    status, doc, headers = _call(service, "/examples/hexagon", token=None)
    assert status == 200 and headers["content-type"] == "application/json"
    assert doc == json.loads(json.dumps(assembly_to_json(load_assembly(EXAMPLES_DIR /
                                                                       "hexagon.json"))))
    for path in ("/examples/nope", "/examples/hexagon.json", "/examples/..%2Fhexagon",
                 "/examples/" + "x" * 2000, "/examples/hexagon/x"):
        status, doc, _ = _call(service, path, token=None)
        assert status == 404 and list(doc) == ["error"] and "\n" not in doc["error"], (path, doc)
    assert _call(service, "/examples/nope")[1]["error"].startswith("no example 'nope'; the "
                                                                  "examples are grid, hexagon")
    assert {"/examples", "/examples/{name}"} <= set(json.loads(_get(service + "/openapi.json"))
                                                    ["paths"])


def _foreign_urls(text: str) -> list[str]:
    return [u for u in URL.findall(text) if u not in SVG_NAMESPACES
            and not re.match(r"https?://(127\.0\.0\.1|localhost)[:/]", u)]


def test_docs_and_page_name_no_other_host(service):
    docs = _get(service + "/docs")
    assert URL.findall(docs) == [], "the /docs page must load nothing from elsewhere"
    for src in re.findall(r"""(?:src|href)=["']([^"']+)""", docs):
        assert src.startswith("/"), src
        urllib.request.urlopen(service + src, timeout=30).close()  # shipped in the package
    for path in ("/", "/static/app.js", "/static/app.css"):
        assert _foreign_urls(_get(service + path)) == [], path


def test_docs_render_offline(page, service):
    page.goto(service + "/docs")
    page.wait_for_selector("text=/plan", timeout=60_000)
    assert page.locator(".opblock-summary-path", has_text="/inspect").count() == 1
    assert "Swagger" in page.title()


# -- the page ---------------------------------------------------------------------------------------

def _wait(pg, *states: str, timeout: int = WAIT_MS) -> str:
    sel = ", ".join(f"body[data-state={s}]" for s in states)
    pg.wait_for_selector(sel, timeout=timeout)
    return pg.get_attribute("body", "data-state")


def _shown_steps(pg) -> list[dict]:
    return [json.loads(s) for s in pg.eval_on_selector_all("#steps tbody tr",
                                                           "rows => rows.map(r => r.dataset.step)")]


def _download(pg, button: str, dest: Path) -> Path:
    with pg.expect_download() as info:
        pg.click(button)
    info.value.save_as(dest)
    return dest


def open_page(pg, url: str, token: str = TOKEN) -> None:
    """Load the planning page and type the service's token in it."""
    pg.goto(url + "/")
    pg.fill("#token", token)
    pg.press("#token", "Enter")
    pg.wait_for_function("document.getElementById('method').options.length > 0")


def plan_file(pg, path: Path, method: str, seed: int) -> float:
    """Choose method and seed, upload ``path`` and wait until the page shows its plan; the
    seconds from the upload to the plan shown, measured here (the page measures its own in
    ``body[data-file-to-plan-s]``)."""
    pg.select_option("#method", method)
    pg.fill("#seed", str(seed))
    t = time.perf_counter()
    pg.set_input_files("#file", str(path))
    state = _wait(pg, "planned", "error")
    seconds = time.perf_counter() - t
    assert state == "planned", pg.inner_text("#message")
    return seconds


def _plan_in_page(pg, url: str, path: Path, method: str, seed: int, out: Path) -> dict:
    """The plan the page shows for ``path`` (its own JSON download, saved in ``out``)."""
    open_page(pg, url)
    plan_file(pg, path, method, seed)
    return json.loads(_download(pg, "#dl-json", out / "page-plan.json").read_text())


def _check_storyboard(pg, doc: dict, tmp_path: Path) -> None:
    """The page's storyboard is the plan: every step's row and facts; navigation and play."""
    steps = doc["steps"]
    n = len(steps)
    assert _shown_steps(pg) == steps
    rows = pg.eval_on_selector_all("#steps tbody tr", "rows => rows.map(r => "
                                   "[...r.cells].map(c => c.textContent))")
    for k, (row, st) in enumerate(zip(rows, steps)):
        assert row[:3] == [str(k + 1), ", ".join(st["moving"]), ", ".join(st["fixed"])]
        assert row[4] == f"{st['score']:.2f}"
        assert row[5] == {"model": "model", "sim": "simulator", "random": "random",
                          "free": "free: no contact"}[st["source"]]
    assert pg.inner_text("#step-title").startswith(f"step 1 of {n}: r = {steps[0]['score']:.2f}")
    for k in range(1, n):
        pg.click("#next")
        assert pg.inner_text("#step-title").startswith(f"step {k + 1} of {n}")
        assert pg.inner_text("dd[data-fact=moving]") == ", ".join(steps[k]["moving"])
        assert pg.inner_text("dd[data-fact=fixed]") == ", ".join(steps[k]["fixed"])
        d = steps[k]["insertion"]
        assert pg.inner_text("dd[data-fact=insertion]").startswith(f"({d[0]:.3f}, {d[1]:.3f})")
    assert pg.is_disabled("#next")
    pg.click("#steps tbody tr:first-child")
    assert pg.inner_text("#step-title").startswith(f"step 1 of {n}") and pg.is_disabled("#prev")
    pg.click("#play")
    pg.wait_for_function(f"document.getElementById('step-title').textContent"
                         f".startsWith('step {n} of {n}')", timeout=60_000)
    pg.wait_for_function("document.getElementById('play').textContent.includes('play')",
                         timeout=10_000)  # it stops at the last step
    # one ghost (dashed, back along the direction) per moving part in the step's picture
    assert pg.locator("#step-view path[stroke-dasharray]").count() == len(steps[-1]["moving"])
    png = _download(pg, "#dl-png", tmp_path / "storyboard.png")
    from PIL import Image

    with Image.open(png) as im:
        assert im.format == "PNG" and im.width >= 600 and im.height >= 300
    svg = ET.parse(_download(pg, "#dl-svg", tmp_path / "storyboard.svg")).getroot()
    assert svg.tag == "{http://www.w3.org/2000/svg}svg"
    assert len(svg.findall("{http://www.w3.org/2000/svg}svg")) == n  # a panel per step


def test_the_page_needs_the_token_like_the_api(page, service):
    page.goto(service + "/")
    page.set_input_files("#file", str(TANGRAM))
    assert _wait(page, "planned", "error") == "error"
    assert "bearer token" in page.inner_text("#message")
    assert page.is_hidden("#assembly-section")


def test_the_page_says_what_is_wrong_in_one_line(page, service, tmp_path):
    """A file that does not read: the service's line; an interlocked assembly: no storyboard,
    the interlocked parts named."""
    open_page(page, service)
    bad = tmp_path / "broken.json"
    bad.write_text("{\"parts\": [")
    page.set_input_files("#file", str(bad))
    assert _wait(page, "planned", "error") == "error"
    assert page.inner_text("#message").startswith("broken.json: not valid JSON")
    dovetail = tmp_path / "dovetail.json"
    dovetail.write_text(json.dumps(DOVETAIL))
    page.set_input_files("#file", str(dovetail))
    assert _wait(page, "planned", "error") == "planned"
    assert "the subassembly {mortise,tenon}: it is interlocked" in page.inner_text("#plan-status")
    assert page.is_hidden("#story-section") and page.is_hidden("#message")


def test_the_page_shows_the_plan_the_api_gives(page, service, tmp_path):
    """A JSON file uploaded in the page: its parts and NDBG circle, then the plan, which is the
    API's plan for the same request; the storyboard steps through it."""
    method, seed = "rap", 5
    doc = _plan_in_page(page, service, TANGRAM, method, seed, tmp_path)
    status, api_doc, _ = _call(service, "/plan", _body(json.loads(TANGRAM.read_text()),
                                                       method=method, seed=seed, rollouts=True))
    assert status == 200 and _same_plan(doc, api_doc)
    asm = load_assembly(TANGRAM)
    assert check_plan(asm, PlanResult.from_json(doc).steps) == []
    labels = page.eval_on_selector_all("#parts-view text", "ts => ts.map(t => t.textContent)")
    assert sorted(labels) == sorted(asm.ids)
    assert page.inner_text("#ndbg-title").startswith("NDBG: ")
    assert page.locator("#ndbg-view path").count() > 0
    _check_storyboard(page, doc, tmp_path)
    seconds = float(page.get_attribute("body", "data-file-to-plan-s"))
    print(f"\ntangram ({method}, seed {seed}): {seconds:.2f} s from the file to the plan shown")
    page.click("#steps tbody tr:first-child")
    page.screenshot(path=str(tmp_path / "page.png"), full_page=True)


def test_an_example_is_one_click_and_planned_as_a_dropped_file(page, service, tmp_path):
    """The page offers the shipped examples before any file: a button (here pressed from the
    keyboard) reads one as a dropped NAME.json through /inspect and plans it at once."""
    from rap.serve.examples import EXAMPLES_DIR, example_list

    open_page(page, service)
    page.wait_for_selector("#examples:not([hidden]) button")
    buttons = page.eval_on_selector_all("#example-buttons button",
                                        "bs => bs.map(b => b.textContent)")
    assert buttons == [e["name"] for e in example_list()]
    page.select_option("#method", "rap")
    page.fill("#seed", "2")
    with page.expect_request(lambda r: "/inspect?" in r.url) as sent:
        page.focus("button[data-example=hexagon]")
        page.keyboard.press("Enter")
    assert sent.value.url.endswith("/inspect?name=hexagon.json")
    assert _wait(page, "planned", "error") == "planned", page.inner_text("#message")
    asm = load_assembly(EXAMPLES_DIR / "hexagon.json")
    labels = page.eval_on_selector_all("#parts-view text", "ts => ts.map(t => t.textContent)")
    assert sorted(labels) == sorted(asm.ids)
    assert page.inner_text("#file-status").startswith(f"hexagon.json: {len(asm.ids)} parts")
    steps = _shown_steps(page)
    assert steps and page.is_visible("#story-section")
    assert page.inner_text("#plan-status").startswith("rap plan of hexagon: robustness R = ")
    assert "expected failed steps" in page.inner_text("#plan-status")  # beside R (issue 37)
    assert "expected attempts with retries" in page.inner_text("#plan-status")
    assert check_plan(asm, [PlanStep.from_json(st) for st in steps]) == []
    page.screenshot(path=str(tmp_path / "page-example.png"), full_page=True)


def test_the_page_says_when_the_assembly_is_unfamiliar(page, service, tmp_path):
    """An arch (a shape kind in no training family) planned by the default search: the page's
    line says that the scorer's guard found it unfamiliar and what it did, as the JSON does."""
    from rap.assembly import assembly_to_json
    from rap.geometry.families import generate

    path = tmp_path / "arch1.json"
    path.write_text(json.dumps(assembly_to_json(generate("arch", 1))))
    doc = _plan_in_page(page, service, path, "search", 0, tmp_path)
    assert doc["guard"]["unfamiliar"] is True
    status = page.inner_text("#plan-status")
    share = round(100 * doc["guard"]["outside"])
    assert (f"; unfamiliar assembly ({share}% of {doc['guard']['operations']} sampled operations "
            f"far from the training data): {doc['guard']['action']}") in status


# -- drawings (rap.cad, the DXF/SVG importer) ---------------------------------------------------------

def seven_part_dxf(path: Path) -> Path:
    """A 7-part DXF in millimetres, with arcs: a base with three round notches, three pegs
    whose round ends sit in them, and three caps notched over the pegs' round tops (bulged
    LWPOLYLINEs; neighbours share each arc)."""
    import ezdxf

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4  # millimetres
    msp = doc.modelspace()
    centres = (15, 40, 65)
    base = [(0, 0, 0), (80, 0, 0), (80, 10, 0)]
    for c in reversed(centres):  # along the top from right to left, each notch dipping down
        base += [(c + 5, 10, -1), (c - 5, 10, 0)]
    base.append((0, 10, 0))
    msp.add_lwpolyline(base, format="xyb", close=True, dxfattribs={"layer": "base"})
    for c in centres:
        msp.add_lwpolyline([(c - 5, 30, 0), (c - 5, 10, 1), (c + 5, 10, 0), (c + 5, 30, 1)],
                           format="xyb", close=True, dxfattribs={"layer": "pegs"})
        msp.add_lwpolyline([(c - 10, 30, 0), (c - 5, 30, -1), (c + 5, 30, 0), (c + 10, 30, 0),
                            (c + 10, 42, 0), (c - 10, 42, 0)],
                           format="xyb", close=True, dxfattribs={"layer": "caps"})
    doc.saveas(path)
    return path


def test_the_page_plans_a_dxf_drawing_as_the_api_does(page, service, tmp_path):
    if importlib.util.find_spec("rap.cad") is None:
        pytest.skip("rap.cad (the DXF/SVG importer of issue 29) is not in this checkout yet")
    pytest.importorskip("ezdxf", reason="ezdxf writes the DXF fixture")
    dxf = seven_part_dxf(tmp_path / "pegs.dxf")
    status, imported, _ = _upload(service, "/import?name=pegs.dxf", dxf.read_bytes())
    assert status == 200, imported
    assert imported["name"] == "pegs" and len(imported["parts"]) == 7
    doc = _plan_in_page(page, service, dxf, "search", 11, tmp_path)
    status, api_doc, _ = _call(service, "/plan", _body(imported, method="search", seed=11,
                                                       rollouts=True))  # as the page asks
    assert status == 200 and _same_plan(doc, api_doc)
    _check_storyboard(page, doc, tmp_path)
    seconds = float(page.get_attribute("body", "data-file-to-plan-s"))
    print(f"\npegs.dxf (search, seed 11): {seconds:.2f} s from the file to the plan shown")
    page.click(f"#steps tbody tr:nth-child({max(1, len(doc['steps']) - 1)})")
    page.screenshot(path=str(tmp_path / "page-dxf.png"), full_page=True)
    if os.environ.get("RAP_PAGE_SCREENSHOT"):  # the README's picture
        page.screenshot(path=os.environ["RAP_PAGE_SCREENSHOT"], full_page=True)


def test_the_page_plans_a_25_part_grid_within_the_default_budget(page, service, tmp_path):
    """A larger drawing than the others (benchmarks/service_scale.py drops a 100-part one): the
    page sends no budget_s, so the service's default applies; the plan it shows is complete and
    valid. No time is asserted."""
    from rap.geometry.families.simple import grid

    asm = grid(5)
    path = tmp_path / "grid25.json"
    path.write_text(json.dumps(assembly_to_json(asm)))
    open_page(page, service)
    with page.expect_request(lambda r: r.url.endswith("/plan") and r.method == "POST") as sent:
        plan_file(page, path, "search", 11)
    assert "budget_s" not in json.loads(sent.value.post_data)
    doc = json.loads(_download(page, "#dl-json", tmp_path / "grid25.plan.json").read_text())
    assert doc["feasible"] is True and len(doc["steps"]) == 24 and len(_shown_steps(page)) == 24
    assert check_plan(asm, PlanResult.from_json(doc).steps) == []


# -- the robot cell (POST /plan's "constraints") ---------------------------------------------------

CELLS = ROOT / "assemblies" / "cells"


def _inspect(pg, url: str, path: Path, method: str = "sim", seed: int = 3) -> None:
    """Open the page, choose method and seed, and read ``path`` without planning it; the robot
    cell's fieldset shows once it is read."""
    open_page(pg, url)
    assert pg.is_hidden("#cell")
    pg.select_option("#method", method)
    pg.fill("#seed", str(seed))
    pg.uncheck("#auto-plan")
    pg.set_input_files("#file", str(path))
    assert _wait(pg, "inspected", "error") == "inspected", pg.inner_text("#message")


def _plan_sent(pg) -> tuple[str, dict]:
    """Click Plan; (the state the page ends in, the body of the POST /plan it sent)."""
    with pg.expect_request(lambda r: r.url.endswith("/plan") and r.method == "POST") as sent:
        pg.click("#plan")
    return _wait(pg, "planned", "error"), json.loads(sent.value.post_data)


def _within_30(insertion, axis) -> bool:  # as tests/plan/cell/test_constraints.py: 3 cross^2 <= dot^2
    dot = insertion[0] * axis[0] + insertion[1] * axis[1]
    cross = axis[0] * insertion[1] - axis[1] * insertion[0]
    return dot > 0 and 3 * cross * cross <= dot * dot


def test_a_plain_plan_sends_no_constraints_and_the_cell_has_the_cli_help(page, service):
    from rap.plan.cell.help import CELL_HELP

    _inspect(page, service, CELLS / "side-peg.json")
    assert page.is_visible("#cell")
    options = page.eval_on_selector_all("#cell-base option", "os => os.map(o => [o.value, "
                                        "o.textContent])")
    assert options == [["", "none"], ["base", "base"], ["peg", "peg"]]
    assert page.get_attribute("#cell-friction", "placeholder") == "0.5"  # the service's default
    for key, text in CELL_HELP.items():  # the CLI's --base ... --layers help, from the schema
        assert page.get_attribute(f"#cell label[data-help={key}]", "title").startswith(text)
    state, body = _plan_sent(page)
    assert state == "planned" and "constraints" not in body
    assert set(body) == {"assembly", "method", "seed"}
    assert "robot cell" not in page.inner_text("#plan-status")


def test_the_perturbed_candidate_is_the_searchs_and_the_page_says_what_became_of_it(page,
                                                                                  service):
    """The checkbox is enabled for the search only and sends ``perturbed_candidate``; the status
    line says what became of the candidate (the answer's details), with the API's help as its
    tooltip."""
    _inspect(page, service, CELLS / "arch.json", method="sim")
    assert page.is_disabled("#perturbed")
    page.select_option("#method", "search")
    assert page.is_enabled("#perturbed")
    assert "perturbed-start" in page.get_attribute("#perturbed-label", "title")
    page.check("#perturbed")
    state, body = _plan_sent(page)
    assert state == "planned" and body["perturbed_candidate"] is True
    status = page.inner_text("#plan-status")
    assert "the best plan on perturbed starts: " in status and "operations simulated" in status
    page.select_option("#method", "sim")  # checked but not the search: not sent
    state, body = _plan_sent(page)
    assert state == "planned" and "perturbed_candidate" not in body
    assert "perturbed starts" not in page.inner_text("#plan-status")


def test_a_cell_that_admits_no_plan_is_one_line_and_no_storyboard(page, service):
    """side-peg's peg enters only from the right: a cone around straight down admits no plan
    (tests/plan/cell/test_constraints.py); the service's line names the flag that blocks it."""
    _inspect(page, service, CELLS / "side-peg.json")
    page.select_option("#cell-base", "base")
    page.fill("#cell-directions", "0,-1:30")
    state, body = _plan_sent(page)
    assert body["constraints"] == {"base": "base", "directions": ["0,-1:30"]}
    assert state == "planned" and page.is_hidden("#story-section") and page.is_hidden("#message")
    status = page.inner_text("#plan-status")
    assert status.startswith("sim: no sequence satisfies the cell's constraints: the subassembly "
                             "{base,peg} cannot be built: every way to split it breaks "
                             "--directions 0,-1:30 (no insertion direction within 30° of (0,-1))")
    assert "\n" not in status
    # a constraint the service refuses: its 400 line, as it is
    page.select_option("#cell-base", "")
    page.fill("#cell-directions", "")
    page.fill("#cell-gravity", "0,-1")
    state, body = _plan_sent(page)
    assert body["constraints"] == {"gravity": "0,-1"} and state == "error"
    assert page.inner_text("#message").startswith("constraints.gravity 0,-1: needs a base part")


def test_a_plan_in_the_cell_obeys_it_and_says_so(page, service, tmp_path):
    """stack.json with its plate in the fixture, one arm, insertion from above: every step moves
    one block onto an assembly holding the plate, within 30 degrees of straight down; the plan
    is the API's for the same request, and the storyboard and status line name the cell."""
    _inspect(page, service, CELLS / "stack.json")
    page.select_option("#cell-base", "plate")
    page.check("#cell-linear")
    page.fill("#cell-directions", " 0, -1 : 30 ")
    state, body = _plan_sent(page)
    assert state == "planned", page.inner_text("#message")
    cell = {"base": "plate", "linear": True, "directions": ["0,-1:30"]}
    assert body["constraints"] == cell
    doc = json.loads(_download(page, "#dl-json", tmp_path / "cell-plan.json").read_text())
    assert doc["feasible"] is True and len(doc["steps"]) == 3
    assert doc["constraints"] == {**cell, "gravity": None, "friction": 0.5, "layers": False}
    for st in doc["steps"]:
        assert len(st["moving"]) == 1 and "plate" in st["fixed"]
        assert _within_30(st["insertion"], (0, -1)), st
    assert check_plan(load_assembly(CELLS / "stack.json"), PlanResult.from_json(doc).steps) == []
    status, api_doc, _ = _call(service, "/plan", json.dumps(body).encode())
    assert status == 200 and _same_plan(doc, api_doc)
    assert _shown_steps(page) == doc["steps"]
    assert ("(robot cell: plate fixed in the fixture, one part per step, insertion within 30° of "
            "(0,-1))") in page.inner_text("#plan-status")
    assert "without gravity" in page.get_attribute("#plan-status", "title")  # the score note
    page.screenshot(path=str(tmp_path / "page-cell.png"), full_page=True)
    svg = ET.parse(_download(page, "#dl-svg", tmp_path / "cell-storyboard.svg")).getroot()
    texts = ["".join(t.itertext()) for t in svg.findall("{http://www.w3.org/2000/svg}text")]
    assert "robot cell: plate fixed in the fixture, one part per step" in texts[1]


# -- the robot program (POST /export) ---------------------------------------------------------------

def _export(url: str, body: bytes, token: str | None = TOKEN):
    """(status, headers, text) of a ``POST /export``."""
    import urllib.error

    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(url + "/export", data=body, headers=headers, method="POST")
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, r.headers, r.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers, exc.read().decode()


def test_export_answers_the_program_as_an_attachment(service):
    """The stack's plan (tests/robot/data) as waypoints, as ``rap-farm export`` writes them; the
    token as for /plan; a plan without a fixture a 422 with the one-arm line; bad input a 400."""
    from tests.robot.cases import STACK, STACK_PLAN

    asm, plan = json.loads(STACK.read_text()), json.loads(STACK_PLAN.read_text())
    body = json.dumps({"assembly": asm, "plan": plan, "format": "waypoints-csv"}).encode()
    status, headers, text = _export(service, body)
    assert status == 200, text
    assert headers["Content-Disposition"] == 'attachment; filename="stack-waypoints.csv"'
    assert headers["Content-Type"].startswith("text/csv")
    assert text.startswith("step,name,motion,part,x_m,") and len(text.splitlines()) == 1 + 24
    assert json.loads(headers["X-Program-Details"])["waypoints"] == 24
    status, _, text = _export(service, body, token=None)
    assert status == 401 and "bearer token" in json.loads(text)["error"]
    plan["constraints"]["base"] = None
    status, _, text = _export(service, json.dumps({"assembly": asm, "plan": plan}).encode())
    assert status == 422 and json.loads(text)["error"].startswith("the plan has no fixture")
    status, _, text = _export(service, b"[]")
    assert status == 400 and json.loads(text)["error"].startswith("request body must be")
    schema = json.loads(_get(service + "/openapi.json"))["paths"]["/export"]["post"]
    body_schema = schema["requestBody"]["content"]["application/json"]["schema"]
    from rap.robot.arms.registry import ARMS, FORMATS

    assert body_schema["properties"]["format"]["enum"] == list(FORMATS)
    assert body_schema["properties"]["arm"]["enum"] == list(ARMS)
    assert "422" in schema["responses"]


def test_the_page_downloads_the_robot_program(page, service, tmp_path):
    """stack.json planned on the page without a base part: the robot program is refused in the
    service's line (a second fixture); planned with the plate in the fixture and one arm, the
    download is the URScript program (a def ... end that the grammar of tests/robot accepts)."""
    from tests.robot.test_writers import parse_urscript

    _inspect(page, service, CELLS / "stack.json")
    state, _ = _plan_sent(page)
    assert state == "planned" and page.is_visible("#dl-program"), page.inner_text("#message")
    with page.expect_request(lambda r: r.url.endswith("/export")) as sent:
        page.click("#dl-program")
    page.wait_for_selector("body[data-program=refused]", timeout=60_000)
    sent_body = json.loads(sent.value.post_data)
    assert set(sent_body) == {"assembly", "plan", "arm", "format"}
    assert (sent_body["arm"], sent_body["format"]) == ("ur5e", "urscript")  # the page's default
    message = page.inner_text("#message")
    assert message.startswith("robot program: the plan has no fixture (made without --base)")
    assert "a two-handed step needs a second fixture" in message and "\n" not in message
    page.select_option("#cell-base", "plate")
    page.check("#cell-linear")
    state, _ = _plan_sent(page)
    assert state == "planned" and page.is_hidden("#message"), page.inner_text("#message")
    with page.expect_download() as info:
        page.click("#dl-program")
    assert info.value.suggested_filename == "stack.script"
    text = (Path(info.value.path())).read_text()
    code = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert code[0] == "def rap_farm_program():" and code[-1] == "end"
    assert parse_urscript(text) == [] and text.count("set_digital_out(0, True)") == 3
    page.wait_for_selector("body[data-program=saved]", timeout=10_000)
    assert page.is_hidden("#message")
    page.screenshot(path=str(tmp_path / "page-program.png"), full_page=True)
