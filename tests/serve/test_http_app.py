"""``rap-farm serve`` end to end: one service (a subprocess on a free loopback port; fixture
``service`` of tests/serve/conftest.py, shared with test_page.py).

Plans over HTTP checked by the swept-area plan checker and against in-process plans, 16 concurrent
requests, malformed and invalid requests (4xx, one line, the service keeps answering), an
interlocked assembly (``"feasible": false``), bearer-token authentication and ``plan --server``;
hostile numbers refused at once while ``/health`` keeps answering, and fuzzed bodies
(tests/fuzz.py, ``RAP_FUZZ_REQUESTS`` of them, default 150) that never get a 5xx.
"""

from __future__ import annotations

import json
import os
import secrets
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

from rap.assembly import AssemblyError, assembly_to_json
from rap.io import load_assembly
from rap.plan.report.result import PlanResult
from rap.plan.report.validate import check_plan

from tests.farm.conftest import ASSEMBLIES, ROOT
from tests.fuzz import plan_bodies

pytestmark = [pytest.mark.ray, pytest.mark.slow]

TRIALS = 8
# one token per process however often this module is imported (pytest imports it as
# serve.test_http_app, the service fixture and test_page.py as tests.serve.test_http_app)
TOKEN = os.environ.setdefault("RAP_TEST_SERVICE_TOKEN", secrets.token_urlsafe(24))
BAD = ROOT / "tests" / "data" / "bad"
DOVETAIL = {"name": "dovetail", "parts": [  # tests/geometry/fixtures.py DOVETAIL
    {"id": "mortise", "polygon": [[0, 0], [10, 0], [10, 4], [6, 4], [7, 1], [3, 1], [4, 4], [0, 4]]},
    {"id": "tenon", "polygon": [[3, 1], [7, 1], [6, 4], [10, 4], [10, 6], [0, 6], [0, 4], [4, 4]]},
]}


def _call(url: str, path: str, body: bytes | None = None, token: str | None = TOKEN,
          method: str | None = None, timeout: float = 300) -> tuple[int, dict, dict]:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(url + path, data=body, headers=headers, method=method)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, json.loads(r.read()), dict(r.headers)
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read()), dict(exc.headers)


def _body(doc: dict | str, **extra) -> bytes:
    """A ``POST /plan`` body; without rollouts unless asked (these tests compare plans with the
    planner's in this process; ``test_the_answer_carries_sequence_success`` asks for them)."""
    extra = {"rollouts": False, **extra}
    if isinstance(doc, str):  # raw assembly text, spliced as is
        return ("{\"assembly\": " + doc + "".join(f", {json.dumps(k)}: {json.dumps(v)}"
                                                 for k, v in extra.items()) + "}").encode()
    return json.dumps({"assembly": doc, **extra}).encode()


def _local_plan(assembly, method: str, seed: int, processes: int = 1) -> dict:
    """The same request planned in this process (the service's settings)."""
    from rap.commands.plan import default_model_path
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.methods import make_planner
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.scoring.scorer import Scorer
    from rap.sim.params import SimParams

    cnn = OperationPredictor.load(default_model_path(), engine="auto") if method == "rap" else None
    problem = PlanningProblem(assembly, SimParams(trials=TRIALS), seed)
    sim = LocalSimulator(processes=processes)
    try:
        return make_planner(method).solve(problem, Scorer(sim, cnn, ScoreCache())).to_json()
    finally:
        sim.close()


def _same_plan(doc: dict, local: dict) -> bool:
    """Equal documents, except the CNN's P(high), which may differ by float32 rounding (the
    service's BLAS runs on other threads)."""
    doc, local = json.loads(json.dumps(doc)), json.loads(json.dumps(local))
    for d in (doc, local):
        d.pop("seconds", None)
        if d.get("sequence_success"):  # the rollouts' own time
            d["sequence_success"].pop("seconds", None)
    conf = [[s.pop("confidence") for s in d.get("steps", [])] for d in (doc, local)]
    return doc == local and all((a is None and b is None) or abs(a - b) < 1e-5
                                for a, b in zip(*conf))


def _tiling():
    from rap.geometry.families.simple import random_tiling

    return random_tiling(6, np.random.default_rng(7), name="tiling6")


def test_a_held_out_assembly_is_planned_validly_and_as_in_process(service):
    asm = _tiling()
    status, doc, headers = _call(service, "/plan", _body(assembly_to_json(asm), method="rap",
                                                          seed=3))
    assert status == 200, doc
    assert {"assembly", "method", "feasible", "units", "robustness", "robustness_interval",
            "trials", "steps", "seconds"} <= set(doc)
    result = PlanResult.from_json(doc)
    assert result.found and check_plan(asm, result.steps) == []
    details = json.loads(headers["x-plan-details"])
    # each step the CNN chose is simulated once for R (the service's cache starts cold)
    assert details["stats"]["eval_simulations"] == sum(s["source"] == "model" for s in doc["steps"])
    assert "eval_seconds" in details
    assert _same_plan(doc, _local_plan(asm, "rap", 3))


def test_16_concurrent_requests_are_planned_concurrently_and_correctly(service):
    hexagon, tiling = load_assembly(ASSEMBLIES / "hexagon.json"), _tiling()
    unique = [(asm, m, seed) for asm in (hexagon, tiling) for m in ("rap", "sim")
              for seed in (11, 12)]
    cases = unique + unique  # concurrent twins share their simulations in the service
    assert len(cases) == 16

    def ask(case):
        asm, m, seed = case
        return _call(service, "/plan", _body(assembly_to_json(asm), method=m, seed=seed))

    with ThreadPoolExecutor(16) as ex:
        answers = list(ex.map(ask, cases))
    local = {(asm.name, m, seed): _local_plan(asm, m, seed) for asm, m, seed in unique}
    for (asm, m, seed), (status, doc, _) in zip(cases, answers):
        assert status == 200, doc
        assert check_plan(asm, PlanResult.from_json(doc).steps) == []
        assert _same_plan(doc, local[asm.name, m, seed]), (asm.name, m, seed)
    status, health, _ = _call(service, "/health")
    assert status == 200 and health["peak_concurrent"] > 1


def test_an_interlocked_assembly_is_a_valid_question(service):
    for method in ("rap", "optimal"):
        status, doc, _ = _call(service, "/plan", _body(DOVETAIL, method=method))
        assert status == 200, doc
        assert doc == {"format": 3, "assembly": "dovetail", "method": method, "feasible": False,
                       "interlocked": ["mortise", "tenon"],
                       "message": "no one-step translation separates the subassembly "
                                  "{mortise,tenon}: it is interlocked, so dovetail has no "
                                  "assembly sequence"}


BAD_REQUESTS = [
    ("not json", b"{\"assembly\": ", 400),
    ("empty body", b"", 400),
    ("not an object", b"[1, 2]", 400),
    ("no assembly", b"{\"method\": \"rap\"}", 400),
    ("unknown key", _body(DOVETAIL, methd="rap"), 400),
    ("unknown method", _body(DOVETAIL, method="best"), 400),
    ("seed not int", _body(DOVETAIL, seed="7"), 400),
    ("seed bool", _body(DOVETAIL, seed=True), 400),
    ("seed float", _body(DOVETAIL, seed=1.5), 400),
    ("seed huge", _body(DOVETAIL, seed=1 << 70), 400),
    ("deep nesting", b"{\"assembly\": " + b"[" * 100000 + b"]" * 100000 + b"}", 400),
    ("huge integer", b"{\"assembly\": {\"parts\": [{\"id\": \"a\", \"polygon\": [[1" + b"0" * 5000
     + b", 0], [1, 0], [0, 1]]}]}}", 400),
    ("too large", b"{\"assembly\": \"" + b"x" * (2 << 20) + b"\"}", 413),
    ("too many parts", _body({"parts": [{"id": f"p{i}", "polygon": [[i, 0], [i + 1, 0], [i, 1]]}
                                        for i in range(1001)]}), 413),  # past the input bounds
    ("budget zero", _body(DOVETAIL, budget_s=0), 400),
    ("rollouts not a boolean", _body(DOVETAIL, rollouts="yes"), 400),
    ("perturbed not a boolean", _body(DOVETAIL, method="search", rollouts=True,
                                      perturbed_candidate=1), 400),
    ("perturbed without rollouts", _body(DOVETAIL, method="search", perturbed_candidate=True), 400),
    ("perturbed with greedy", _body(DOVETAIL, method="sim", rollouts=True,
                                    perturbed_candidate=True), 400),
    ("budget not a number", _body(DOVETAIL, budget_s="60"), 400),
    ("budget over the cap", _body(DOVETAIL, budget_s=601), 413),
]


@pytest.mark.parametrize("name,body,status", BAD_REQUESTS, ids=[c[0] for c in BAD_REQUESTS])
def test_malformed_requests_get_4xx_and_one_line(service, name, body, status):
    got, doc, _ = _call(service, "/plan", body, method="POST")
    assert got == status, doc
    assert list(doc) == ["error"] and "\n" not in doc["error"] and doc["error"]


@pytest.mark.parametrize("path", sorted(BAD.glob("*.json")), ids=lambda p: p.stem)
def test_invalid_assemblies_get_the_cli_message(service, path):
    text = path.read_text()
    status, doc, _ = _call(service, "/plan", _body(text))
    assert status == 400, doc
    with pytest.raises(AssemblyError) as cli:
        load_assembly(path)
    if "not valid JSON" not in str(cli.value):  # syntax errors name other positions
        where = f"part {cli.value.part!r}: " if cli.value.part is not None else ""
        assert doc["error"] == f"assembly: {where}{cli.value.problem}"


TANGRAM = ROOT / "assemblies" / "unseen" / "tangram.json"
FUZZ_REQUESTS = int(os.environ.get("RAP_FUZZ_REQUESTS", "150"))


def test_a_tiny_hostile_file_is_refused_at_once_while_health_answers(service):
    tiny = TANGRAM.read_text().replace("[0,0]", "[1e-1000000,0]", 1)  # a few hundred bytes
    huge = TANGRAM.read_text().replace("[0,0]", "[1e10000000,0]", 1)
    stop, health = threading.Event(), []  # (asked, answered, status) of each /health call

    def poll():  # the harness's bound: each /health answer within 5 s, else the call raises
        while not stop.is_set():
            asked = time.monotonic()
            status = _call(service, "/health", timeout=5)[0]
            health.append((asked, time.monotonic(), status))
            stop.wait(0.05)  # a pace, not an order: the times above say what overlapped

    poller = ThreadPoolExecutor(1)
    polling = poller.submit(poll)
    try:
        for text, needle in ((tiny, "more than 6 digits after the point"),
                             (huge, "out of range (|x| <= 10^9)")):
            for _ in range(3):
                status, doc, _ = _call(service, "/plan", _body(text), timeout=10)
                assert status == 400 and needle in doc["error"], doc
                assert doc["error"].startswith("assembly: part 'large-a': coordinate 1E")
        # a valid request at the worst case of validation (a 10,000-vertex star, seconds of exact
        # work on a reader thread): planned or 503 past the read budget, never a blocked loop
        sent = time.monotonic()
        status, doc, _ = _call(service, "/plan", _body(_star(10_000), method="sim"), timeout=60)
        answered = time.monotonic()
        assert status in (200, 503), doc
        # a /health asked after the star and answered before it: answered while it was validated
        assert any(sent <= asked and done <= answered for asked, done, _ in health), \
            (sent, answered, health[-5:])
    finally:
        stop.set()
        polling.result(timeout=30)
        poller.shutdown()
    assert health and {status for _, _, status in health} == {200}


def _star(q: int) -> dict:
    import math

    pts = [[round((10**8 if k % 2 == 0 else 10**5) * math.cos(2 * math.pi * k / q)),
            round((10**8 if k % 2 == 0 else 10**5) * math.sin(2 * math.pi * k / q))]
           for k in range(q)]
    return {"name": "star", "parts": [{"id": "star", "polygon": pts}]}


@settings(max_examples=FUZZ_REQUESTS, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(body=plan_bodies())
def test_fuzzed_requests_get_a_4xx_or_a_plan_never_a_5xx(service, body):
    status, doc, _ = _call(service, "/plan", body, method="POST", timeout=120)
    assert status in (200, 400, 413), (status, doc)
    if status == 200:
        assert doc["feasible"] in (True, False, None) and doc["assembly"]
    else:
        assert list(doc) == ["error"] and "\n" not in doc["error"] and doc["error"]


def test_authentication_and_other_routes(service):
    body = _body(DOVETAIL)
    assert _call(service, "/plan", body, token=None)[0] == 401
    assert _call(service, "/plan", body, token="x" * 32)[0] == 401
    status, doc, headers = _call(service, "/health", token=None)
    assert status == 401 and doc["error"] and headers.get("www-authenticate") == "Bearer"
    assert _call(service, "/nope")[0] == 404
    assert _call(service, "/plan", method="GET")[0] == 405
    with urllib.request.urlopen(service + "/docs", timeout=30) as r:
        assert r.status == 200
    with urllib.request.urlopen(service + "/openapi.json", timeout=30) as r:
        spec = json.loads(r.read())
    assert "/plan" in spec["paths"] and "/health" in spec["paths"]


def test_the_service_still_plans_after_the_bad_requests(service):
    status, health, _ = _call(service, "/health")
    assert status == 200 and health["status"] == "ok" and health["workers"] == 2
    asm = load_assembly(ASSEMBLIES / "hexagon.json")
    status, doc, _ = _call(service, "/plan", _body(assembly_to_json(asm), method="sim", seed=1))
    assert status == 200 and check_plan(asm, PlanResult.from_json(doc).steps) == []


def _cli(*args, cwd: Path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("RAP_FARM_TOKEN", None)
    return subprocess.run([sys.executable, "-m", "rap.cli", "plan", *map(str, args)],
                          capture_output=True, text=True, env=env, cwd=cwd, timeout=300)


def test_plan_server_prints_and_writes_what_the_service_planned(service, tmp_path):
    src = ASSEMBLIES / "hexagon.json"
    out, pic = tmp_path / "plan.json", tmp_path / "plan.png"
    p = _cli(src, "--server", service, "--token", TOKEN, "--seed", "5", "--out", out,
             "--picture", pic, "--no-rollouts", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "robustness R" in p.stdout and "hexagon: search plan" in p.stdout  # the default method
    status, doc, _ = _call(service, "/plan", _body(json.loads(src.read_text()), seed=5))
    assert _same_plan(json.loads(out.read_text()), doc)
    assert pic.stat().st_size > 1000

    dove = tmp_path / "dovetail.json"
    dove.write_text(json.dumps(DOVETAIL))
    p = _cli(dove, "--server", service, "--token", TOKEN, "--out", tmp_path / "d.json",
             cwd=tmp_path)
    assert p.returncode == 1 and "interlocked" in p.stderr and "Traceback" not in p.stderr
    assert json.loads((tmp_path / "d.json").read_text())["feasible"] is False

    p = _cli(dove, "--server", service, cwd=tmp_path)  # no token
    assert p.returncode == 2 and "not authorised" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_the_answer_carries_sequence_success_measured_on_the_pool(service):
    """``"rollouts": true`` (the API's default): the plan measured by rollouts on the service's
    simulation pool, each step with its execution (plan format 3)."""
    status, doc, _ = _call(service, "/plan", _body(json.loads(
        (ASSEMBLIES / "hexagon.json").read_text()), seed=5, rollouts=True))
    assert status == 200 and doc["format"] == 3
    seq = doc["sequence_success"]
    assert seq["rollouts"] >= 100 and seq["interval"][0] <= seq["rate"] <= seq["interval"][1]
    assert seq["chosen_by"] == "sequence success" and len(seq["candidates"]) >= 2
    assert all(s["execution"]["reached"] >= 1 for s in doc["steps"][:1])


def test_the_perturbed_candidate_is_measured_on_the_services_pool(service, tmp_path):
    """``"perturbed_candidate": true`` (``rap-farm plan --perturbed-candidate`` through
    ``--server``): the operations are simulated from perturbed starts on the service's pool (the
    count in the answer's details) and the choice measures at most one more plan."""
    from rap.serve.api import DETAILS_HEADER

    arch = json.loads((ASSEMBLIES / "cells" / "arch.json").read_text())
    status, doc, headers = _call(service, "/plan", _body(arch, method="search", seed=5,
                                                          rollouts=True, perturbed_candidate=True))
    assert status == 200 and doc["format"] == 3, doc
    details = {k.lower(): v for k, v in headers.items()}[DETAILS_HEADER.lower()]
    stats = json.loads(details)["stats"]
    assert stats["perturbed_simulated"] >= 1, stats
    flagged = [c for c in doc["sequence_success"]["candidates"] if c.get("perturbed_starts")]
    assert len(flagged) == (stats["perturbed_outcome"] == "offered")
    assert doc["sequence_success"]["rollouts"] >= 100
    p = _cli(ASSEMBLIES / "cells" / "arch.json", "--server", service, "--token", TOKEN, "--seed",
             "5", "--perturbed-candidate", cwd=tmp_path)  # the flag through the client
    assert p.returncode == 0, p.stderr
    assert "perturbed-start scores" in p.stdout


def test_a_small_budget_gets_the_searchs_best_plan_and_greedy_budget_spent(service):
    """``budget_s`` over HTTP: the search stops simulating by time and answers a complete, valid
    plan with its bound (greedy's start cut, the model choosing its levels left); simulator-only
    greedy, without a time limit, answers "budget spent". No time is asserted: 50 ms is far below
    either's own time on any machine (0.4 s was not: greedy at the service's 8 trials fit in it)."""
    from rap.geometry.families.simple import grid

    asm = grid(5)
    status, doc, headers = _call(service, "/plan", _body(assembly_to_json(asm), budget_s=0.05))
    assert status == 200 and doc["feasible"] is True, doc
    assert json.loads(headers["x-plan-details"])["stats"]["stopped"] == "time"
    plan = PlanResult.from_json(doc)
    assert len(plan.steps) == len(asm) - 1 and check_plan(asm, plan.steps) == []
    assert doc["bound"]["robustness_upper"] >= doc["robustness"]
    # its own seed: none of the search's simulations (greedy's start, the evaluation) is cached
    status, doc, _ = _call(service, "/plan", _body(assembly_to_json(asm), method="sim",
                                                   budget_s=0.05, seed=12345))
    assert status == 200 and doc["feasible"] is None and doc["status"] == "budget spent", doc


def test_search_options_travel_with_the_request(service, tmp_path):
    src = ASSEMBLIES / "hexagon.json"
    out = tmp_path / "p.json"
    p = _cli(src, "--server", service, "--token", TOKEN, "--simulations", "1000", "--optimism",
             "1", "--out", out, cwd=tmp_path)  # full optimism: every step from the simulator
    assert p.returncode == 0, p.stderr
    assert all(step["source"] == "sim" for step in json.loads(out.read_text())["steps"])
    # without simulations (the default spends them where they decide) the model chooses
    plain = _call(service, "/plan", _body(json.loads(src.read_text()),
                                          options={"simulations": 0}))[1]
    assert not all(step["source"] == "sim" for step in plain["steps"])
    status, doc, _ = _call(service, "/plan", _body(json.loads(src.read_text()),
                                                   options={"optimism": 2}))
    assert status == 400 and "options.optimism 2" in doc["error"]
