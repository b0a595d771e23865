"""The written waypoints (CSV, JSON), and the URScript grammar the UR programs are held to
(tests/robot/arms/test_urscript.py, tests/serve/test_page.py)."""

from __future__ import annotations

import csv
import json
import re

from rap.robot.writers import WAYPOINT_COLUMNS

from tests.robot.cases import STACK, STACK_PLAN

NUM = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"
POSE = rf"p\[{NUM}(?:, {NUM}){{5}}\]"
JOINTS = rf"\[{NUM}(?:, {NUM}){{5}}\]"
GRAMMAR = [
    re.compile(r"#.*"),
    re.compile(r"def [a-z_]+\(\):"),
    re.compile(rf"  set_tcp\({POSE}\)"),
    re.compile(rf"  set_target_payload\({NUM}, \[{NUM}, {NUM}, {NUM}\]\)"),
    re.compile(rf"  movej\({JOINTS}, a={NUM}, v={NUM}\)  # [a-z_]+"),
    re.compile(rf"  movel\({POSE}, a={NUM}, v={NUM}, r=0\)  # [a-z_]+"),
    re.compile(r"  set_digital_out\([0-7], (True|False)\)"),
    re.compile(rf"  sleep\({NUM}\)"),
    re.compile(r"  # .*"),
    re.compile(r"end"),
]


def parse_urscript(text: str) -> list[str]:
    """The lines the grammar does not accept (a program is one def ... end, lines indented in
    it), and a check that def and end pair."""
    bad = [line for line in text.splitlines() if not any(g.fullmatch(line) for g in GRAMMAR)]
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    if not (lines and lines[0].startswith("def ") and lines[-1] == "end"):
        bad.append("<def ... end>")
    return bad


def test_the_grammar_rejects_a_broken_line():
    assert parse_urscript("def f():\n  movel(p[1, 2], a=1, v=1)  # x\nend\n")
    assert parse_urscript("def f():\n  movej(p[1, 2, 3, 4, 5, 6], a=1, v=1)  # x\nend\n")
    assert parse_urscript("def f():\n  movel(p[1, 2, 3, 4, 5, 6], a=1, v=1, r=0.01)  # x\nend\n")


def test_export_writes_csv_and_json_waypoints(tmp_path, run_cli):
    out = tmp_path / "w.csv"
    code, text, _ = run_cli("export", STACK_PLAN, "--assembly", STACK, "-o", out)
    assert code == 0 and "24 waypoints" in text
    rows = list(csv.DictReader(out.open()))
    assert tuple(rows[0]) == WAYPOINT_COLUMNS and len(rows) == 24
    assert [r["action"] for r in rows[:8]] == ["", "grip_on", "", "", "", "", "grip_off", ""]
    out = tmp_path / "w.json"
    code, _, _ = run_cli("export", STACK_PLAN, "--assembly", STACK, "-o", out)
    doc = json.loads(out.read_text())
    assert code == 0 and doc["units"] == "m" and doc["plane"] == "vertical"
    assert len(doc["waypoints"]) == 24
    out = tmp_path / "p.script"
    code, _, _ = run_cli("export", STACK_PLAN, "--assembly", STACK, "--arm", "ur5e", "-o", out)
    assert code == 0 and parse_urscript(out.read_text()) == []
