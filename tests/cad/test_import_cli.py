"""``rap-farm import`` and drawings given to the other commands, through ``rap.cli.main``."""

from __future__ import annotations

import json

import ezdxf
import pytest

from rap.io import load_assembly
from tests.cad import fixtures as F


def _dxf(tmp, name, draw):
    doc = ezdxf.new("R2010", units=F.MM)
    draw(doc.modelspace())
    path = tmp / f"{name}.dxf"
    doc.saveas(path)
    return path


def open_loop(m):
    m.add_line((0, 0), (10, 0))
    m.add_line((10, 0), (0, 10))
    m.add_line((0, 10), (0, 0.5))


def self_intersection(m):
    m.add_lwpolyline([(0, 0), (10, 10), (10, 0), (0, 5)], close=True, dxfattribs={"layer": "bow"})


def overlap(m):
    m.add_lwpolyline([(0, 0), (10, 0), (10, 10), (0, 10)], close=True, dxfattribs={"layer": "a"})
    m.add_lwpolyline([(5, 5), (15, 5), (15, 15), (5, 15)], close=True, dxfattribs={"layer": "b"})


def no_loop(m):
    m.add_text("no parts here")
    m.add_point((1, 1))


#: (name, drawing writer or SVG text, the words the one-line error must contain)
BAD = [
    ("open", open_loop, ["LINE", "layer '0'", "open loop", "0.50 mm", "--tolerance 1 closes it"]),
    ("selfx", self_intersection, ["LWPOLYLINE", "layer 'bow'",
                                  "self-intersection near (3.33, 3.33)", "--parts face"]),
    ("overlap", overlap, ["layer 'a'", "layer 'b'", "parts 'a' and 'b' overlap"]),
    ("noloop", no_loop, ["no closed loop found", "1 TEXT"]),
]


@pytest.mark.parametrize("name,drawing,words", BAD, ids=[b[0] for b in BAD])
def test_a_bad_drawing_is_one_line_exit_2_and_writes_nothing(run_cli, tmp_path, name, drawing,
                                                             words):
    path = (F.write(tmp_path, f"{name}.svg", drawing) if isinstance(drawing, str)
            else _dxf(tmp_path, name, drawing))
    out = tmp_path / "out.json"
    code, stdout, err = run_cli("import", path, "-o", out)
    assert code == 2, (stdout, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"rap-farm: error: {path}: ")
    for w in words:
        assert w in lines[0], lines[0]
    assert not out.exists()


def test_bad_options_are_one_line(run_cli, tmp_path):
    """``rap.cad`` names its options (``units 'furlong': ...``); the command names the flags."""
    path = F.dxf_bulged_pair(tmp_path)
    for args, message in (
            (["--tolerance", "1e-7"], "--tolerance 1e-7: finer than the coordinate grid 1e-6 of "
                                      "assembly files (at most 6 digits after the point)"),
            (["--tolerance", "abc"], "--tolerance 'abc': not a number"),
            (["--units", "furlong"], "--units 'furlong': choose one of mm, cm, m, in"),
            (["--parts", "blob"], "--parts 'blob': choose one of auto, loop, layer, face"),
            (["--layers", "nope"], "--layers 'nope': no such layer in the drawing (layers: A, "
                                   "B)"),
            (["--scale", "-1"], "--scale -1.0: must be a positive number")):
        code, _, err = run_cli("import", path, "-o", tmp_path / "o.json", *args)
        assert code == 2 and err == f"rap-farm: error: {message}\n", err
    code, _, err = run_cli("import", path, "-o", tmp_path / "o.txt")
    assert code == 2 and "must end in .json" in err


def test_import_writes_the_assembly_and_prints_the_summary(run_cli, tmp_path):
    path = F.dxf_small_gap(tmp_path, 0.004)
    out = tmp_path / "sub" / "gap.json"
    code, stdout, err = run_cli("import", path, "-o", out, "--tolerance", "0.01")
    assert code == 0, err
    assert "1 parts (0 holes) as loops, 3 vertices, 1 gaps closed, unit mm" in stdout
    assert "tolerance 0.01 mm" in stdout
    doc = json.loads(out.read_text())
    assert doc["name"] == "small_gap" and doc["parts"][0]["polygon"] == [[0, 0], [10, 0], [0, 10]]
    assert load_assembly(out) == load_assembly(path)
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".tmp-")]


def test_an_unwritable_output_is_exit_3(run_cli, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = run_cli("import", F.dxf_bulged_pair(tmp_path), "-o", blocker / "a.json")
    assert code == 3 and str(blocker / "a.json") in err and len(err.strip().splitlines()) == 1


def test_other_commands_take_the_drawing(run_cli, tmp_path):
    path = F.dxf_bulged_pair(tmp_path)
    code, out, err = run_cli("inspect", path, "--json")
    assert code == 0, err
    assert json.loads(out)["parts"] == ["A", "B"]
    code, _, err = run_cli("show", F.write(tmp_path, "touch.svg", F.SVG_TOUCHING_ARC), "-o",
                           tmp_path / "touch.png")
    assert code == 0 and (tmp_path / "touch.png").stat().st_size > 0, err
    code, out, err = run_cli("inspect", F.write(tmp_path, "plain.svg", F.SVG_UNITLESS))
    assert code == 0 and "r" in out, err  # no physical size: a user unit is a CSS px


@pytest.mark.slow
def test_a_seven_part_dxf_with_arcs_is_planned(run_cli, tmp_path, monkeypatch):
    monkeypatch.setenv("RAP_CACHE", str(tmp_path / "cache.json"))
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    path = F.dxf_seven(tmp_path)
    code, out, err = run_cli("plan", path, "--method", "sim", "--trials", "8", "--workers", "1",
                             "--out", tmp_path / "plan.json")
    assert code == 0, err
    plan = json.loads((tmp_path / "plan.json").read_text())
    seen = {p for step in plan["steps"] for p in step["moving"] + step["fixed"]}
    assert len(plan["steps"]) == 6 and seen == {"tray", "b1", "b2", "b3", "cap", "d1", "d2"}


def test_the_request_body_for_a_drawing_is_its_imported_assembly(tmp_path):
    """``plan --server drawing.dxf`` sends the assembly the drawing imports to, exactly."""
    from decimal import Decimal

    from rap.client import plan_body
    from rap.serve.api import parse_plan_request
    path = F.dxf_seven(tmp_path)
    body = plan_body(path, "sim", seed=3)
    assembly, method, seed, options, _ = parse_plan_request(body)
    imported = load_assembly(path)
    assert (method, seed, options) == ("sim", 3, {})
    assert assembly.geometry_hash == imported.geometry_hash and assembly.ids == imported.ids
    assert json.loads(body, parse_float=Decimal)["assembly"]["name"] == imported.name
