"""``rap-farm simulate``: output contract and infeasible operations."""

from __future__ import annotations

import json

import pytest

from rap.assembly import assembly_to_json
from rap.cli import main

from .fixtures import ASSEMBLIES


def run(argv) -> int:
    """Exit status of ``rap-farm ARGV``."""
    try:
        main(argv)
    except SystemExit as exc:
        return exc.code or 0
    return 0


@pytest.fixture
def tight_file(tmp_path):
    path = tmp_path / "tight.json"
    path.write_text(json.dumps(assembly_to_json(ASSEMBLIES["tight"])))
    return path


def test_json_output(tight_file, tmp_path, capsys):
    gif, png = tmp_path / "t.gif", tmp_path / "t.png"
    assert run(["simulate", str(tight_file), "--moving", "peg", "--direction", "0,-1",
                "--trials", "6", "--seed", "3", "--json", "--gif", str(gif), "--images", str(png)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == {"score", "successes", "trials", "seconds", "params"}
    assert doc["trials"] == 6 and doc["score"] == doc["successes"] / 6
    assert doc["params"]["eta"] == 9.0
    assert gif.stat().st_size > 0 and png.stat().st_size > 0


def test_same_seed_same_score(tight_file, capsys):
    scores = []
    for _ in range(2):
        assert run(["simulate", str(tight_file), "--moving", "peg", "--direction", "0,-1.0",
                    "--trials", "8", "--json"]) == 0
        scores.append(json.loads(capsys.readouterr().out)["successes"])
    assert scores[0] == scores[1]


@pytest.mark.parametrize("args,needle", [
    (["--moving", "peg", "--direction", "1,-1"], "not a feasible operation"),
    (["--moving", "nope", "--direction", "0,-1"], "no part"),
    (["--moving", "peg", "--direction", "0,0"], "zero"),
    (["--moving", "peg", "--direction", "0,x"], "not numbers"),
    (["--moving", "peg,slot", "--direction", "0,-1"], "fixed"),
])
def test_bad_input_exits_2_with_one_line(tight_file, capsys, args, needle):
    assert run(["simulate", str(tight_file), *args, "--trials", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and "\n" not in err
