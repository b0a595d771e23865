"""POST /export's contract without a service (rap.serve.robot_program): the program of a plan
and its assembly as rap-farm export writes it, its file name, and the one-line refusals."""

from __future__ import annotations

import copy
import csv
import io
import json

import pytest

from rap.robot.arms.export import export_text
from rap.robot.cell import Cell, with_
from rap.robot.program import build_program
from rap.serve.api import BadRequest
from rap.serve.robot_program import (PROGRAM_DETAILS_HEADER, parse_export_request,
                                       program_file)

from tests.robot.cases import STACK, STACK_PLAN
from tests.robot.test_writers import parse_urscript

ASSEMBLY = json.loads(STACK.read_text())  # assemblies/cells/stack.json: a plate and 3 blocks
PLAN = json.loads(STACK_PLAN.read_text())  # planned with --base plate --gravity 0,-1 --linear
SQUARES = {"name": "two", "parts": [{"id": "a", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]]},
                                    {"id": "b", "polygon": [[1, 0], [2, 0], [2, 1], [1, 1]]}]}


def body(**changes) -> bytes:
    doc = {"assembly": ASSEMBLY, "plan": PLAN, **changes}
    return json.dumps({k: v for k, v in doc.items() if v is not None}).encode()


def export(data: bytes):
    return program_file(parse_export_request(data))


def refusal(data: bytes) -> BadRequest:
    with pytest.raises(BadRequest) as err:
        export(data)
    assert "\n" not in err.value.message
    return err.value


@pytest.mark.parametrize("arm, fmt, name, media", [
    ("ur5e", None, "stack.script", "text/plain"),  # a UR's default format
    ("ur10e", "urscript", "stack.script", "text/plain"),
    (None, "waypoints-csv", "stack-waypoints.csv", "text/csv"),  # the cell's arm, the Panda
    ("ur5e", "waypoints-json", "stack-waypoints.json", "application/json"),
    (None, None, "stack-trajectory.yaml", "application/yaml"),  # the Panda's default format
])
def test_the_program_is_what_rap_farm_export_writes(arm, fmt, name, media):
    from rap.robot.inputs import load_plan_and_assembly

    plan, _, asm = load_plan_and_assembly(STACK_PLAN, STACK)
    got = export(body(arm=arm, format=fmt))
    cell = with_(Cell(), "robot", arm=arm or "panda")
    program = build_program(plan, asm, cell)
    assert got.text == export_text(program, fmt or {"panda": "joint-trajectory-yaml"}.get(
        cell.robot.arm, "urscript"))[0]
    assert (got.filename, got.media_type) == (name, media)
    assert got.headers["Content-Disposition"] == f'attachment; filename="{name}"'
    details = json.loads(got.headers[PROGRAM_DETAILS_HEADER])
    assert details["steps"] == 3 and details["waypoints"] == 24 and details["fixture"] == "plate"
    assert details["solves"] > 24 and details["worst_position_m"] < 1e-4
    assert details["arm"] == (arm or "panda")


def test_the_3_part_stack_is_a_urscript_program_and_waypoints():
    text = export(body(arm="ur5e")).text
    assert parse_urscript(text) == []
    assert [ln for ln in text.splitlines() if not ln.startswith("#")][0] == "def rap_farm_program():"
    assert text.count("set_digital_out(0, True)") == 3
    assert "# step 3: block3 into {block1,block2,plate}" in text
    rows = list(csv.DictReader(io.StringIO(export(body(format="waypoints-csv")).text)))
    assert len(rows) == 24 and [r["part"] for r in rows[::8]] == ["block1", "block2", "block3"]


def test_a_cell_travels_as_toml_text():
    moved = export(body(format="waypoints-json", cell="[assembly]\nposition_m = [0.45, 0.1]\n"))
    doc = json.loads(moved.text)
    assert doc["cell"]["assembly"]["position_m"] == [0.45, 0.1]
    base = json.loads(export(body(format="waypoints-json")).text)
    a, b = base["waypoints"][4], doc["waypoints"][4]  # step 1's approach, moved with the assembly
    assert (b["x_m"] - a["x_m"], b["y_m"] - a["y_m"]) == pytest.approx((-0.05, 0.1))


def _no_base():
    d = copy.deepcopy(PLAN)
    d["constraints"]["base"] = None
    return d


def _away_from_the_fixture():
    """block3 onto block2 apart, then the pair onto {block1, plate}: a valid order, two hands."""
    d = copy.deepcopy(PLAN)
    d["steps"][1].update(moving=["block3"], fixed=["block2"])
    d["steps"][2].update(moving=["block2", "block3"], fixed=["block1", "plate"])
    return d


@pytest.mark.parametrize("plan, cell, words", [
    (_no_base(), None, "the plan has no fixture (made without --base), so its first step joins "
                       "two loose parts: a two-handed step needs a second fixture"),
    (_away_from_the_fixture(), None, "step 2 joins block3 to {block2} away from the fixture "
                                     "plate: a two-handed step needs a second fixture"),
    (PLAN, "[assembly]\nposition_m = [3.0, 0.0]\n",
     "step 1 (block1), waypoint transit at (3.000, 0.000, 0.150) m is unreachable: beyond the "
     "panda's reach"),
], ids=["no-fixture", "away-from-the-fixture", "unreachable"])
def test_a_plan_one_arm_cannot_build_is_a_422_and_one_line(plan, cell, words):
    err = refusal(body(plan=plan, cell=cell))
    assert err.status == 422 and err.message.startswith(words), err.message


def _bad_plan(**changes):
    return {**PLAN, **changes}


BAD = [  # (name, body, status, the line's start)
    ("not-json", b"{\"assembly\": ", 400, "request body is not valid JSON"),
    ("not-an-object", b"[1]", 400, "request body must be a JSON object"),
    ("unknown-key", body(method="sim"), 400, "unknown key 'method' (expected assembly, plan, "
                                             "arm, format, cell)"),
    ("no-plan", json.dumps({"assembly": ASSEMBLY}).encode(), 400, "missing key 'plan'"),
    ("no-assembly", json.dumps({"plan": PLAN}).encode(), 400, "missing key 'assembly'"),
    ("format", body(format="pdf"), 400, "format 'pdf': unknown (choose one of urscript, "
                                        "joint-trajectory-yaml,"),
    ("format-not-the-arms", body(format="urscript"), 400, "format 'urscript': the panda (Franka "
                                                          "Emika Panda) does not take it"),
    ("arm", body(arm="ur3"), 400, "arm 'ur3': unknown (known: panda, ur5e, ur10e)"),
    ("arm-not-text", body(arm=5), 400, "arm 5: choose one of panda, ur5e, ur10e"),
    ("cell-not-text", body(cell={"assembly": {}}), 400, "cell: must be a cell file's TOML text"),
    ("cell-not-toml", body(cell="[assembly"), 400, "cell: not a TOML file"),
    ("cell-key", body(cell="[motion]\ninsertion_speed_m_s = -1\n"), 400,
     "cell: motion.insertion_speed_m_s: expected a number > 0, got -1"),
    ("assembly", body(assembly={"parts": [{"id": "a", "polygon": [[0, 0], [1, 0]]}]}), 400,
     "assembly: part 'a'"),
    ("plan-not-a-plan", body(plan=[1, 2]), 400, "plan: not a plan document"),
    ("plan-shape", body(plan={"feasible": True}), 400, "plan: not a plan document (KeyError"),
    ("plan-not-found", body(plan=_bad_plan(feasible=None, status="budget spent", message="x")),
     400, "plan: the plan found no sequence (x): nothing to build"),
    ("another-assembly", body(assembly=SQUARES), 400, "assembly: has no part 'block1' of the "
                                                      "plan's step 1: not the plan's assembly"),
    ("steps", body(plan=_bad_plan(steps=PLAN["steps"][:2])), 400,
     "plan: 2 steps for 4 parts (expected 3): not a plan of this assembly"),
    ("huge-number", body(plan=_bad_plan(seconds=1)).replace(b'"seconds": 1', b'"seconds": 1e999'),
     400, "plan: number 1E+999 is out of range"),
]


@pytest.mark.parametrize("name, data, status, start", BAD, ids=[c[0] for c in BAD])
def test_bad_requests_are_a_4xx_and_one_line(name, data, status, start):
    err = refusal(data)
    assert (err.status, err.message[:len(start)]) == (status, start), err.message


def test_too_many_parts_is_a_413():
    with pytest.raises(BadRequest) as err:
        parse_export_request(body(), max_parts=3)
    assert err.value.status == 413 and err.value.message.startswith("assembly: 4 parts")


def test_the_pages_arms_and_formats_are_the_registrys():
    """rap/serve/static/app.js's ARM_FORMATS and index.html's arm select: the registry's arms
    and, for each, its formats in its order (the first the default)."""
    import re
    from pathlib import Path

    from rap.robot.arms.registry import ARMS

    static = Path(__file__).resolve().parents[2] / "rap" / "serve" / "static"
    js = (static / "app.js").read_text()
    table = js.split("const ARM_FORMATS = {", 1)[1].split("};", 1)[0]
    page = {arm: re.findall(r'\["([a-z-]+)",\s*"', body)
            for arm, body in re.findall(r"(\w+): \[(.*?)\]\],", table, flags=re.S)}
    assert page == {name: list(spec.formats) for name, spec in ARMS.items()}
    html = (static / "index.html").read_text()
    select = html.split('id="program-arm"', 1)[1].split("</select>", 1)[0]
    assert sorted(re.findall(r'value="(\w+)"', select)) == sorted(ARMS)
