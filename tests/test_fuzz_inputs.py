"""Fuzzing the readers with hostile input (tests/fuzz.py): every answer is one line, in bounded time.

Files go through ``rap.io.load_assembly`` (what every command reads with) and request bodies
through ``rap.serve.api.parse_plan_request`` (the service's reader, which imports neither ray nor
fastapi); a few hand-picked hostile files go through the console script itself. The time bound
is the harness's: Hypothesis's per-example ``deadline`` and the subprocess ``timeout``, never an
assertion on a measured time. ``RAP_FUZZ_EXAMPLES`` raises the number of examples (default 200).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from datetime import timedelta
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings

from rap.assembly import Assembly, AssemblyError, assembly_to_json
from rap.client import exact_json
from rap.serve.api import BadRequest, parse_plan_request
from rap.io import load_assembly
from rap.plan.methods import DEFAULT_METHOD, METHODS
from rap.seeds import DEFAULT_ROOT_SEED

from tests.fuzz import assembly_texts, plan_bodies

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = int(os.environ.get("RAP_FUZZ_EXAMPLES", "200"))
FUZZ = settings(max_examples=EXAMPLES, deadline=timedelta(seconds=5), derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _one_line(message: str) -> None:
    assert "\n" not in message and "Traceback" not in message, message
    assert 0 < len(message) <= 600, message


@FUZZ
@given(text=assembly_texts())
def test_a_hostile_file_is_read_or_refused_in_one_line(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hostile.json"
        path.write_bytes(text.encode("utf-8", "surrogatepass"))
        try:
            assembly = load_assembly(path)
        except AssemblyError as exc:
            _one_line(str(exc))
            assert str(exc).startswith(f"{path}: "), str(exc)
        else:  # a mutation that kept the assembly valid: written back, it reads the same
            again = Path(tmp) / "again.json"
            again.write_text(exact_json(assembly_to_json(assembly)), encoding="utf-8")
            assert load_assembly(again) == assembly


@FUZZ
@given(body=plan_bodies())
def test_a_hostile_request_is_parsed_or_refused_with_a_4xx(body):
    try:
        assembly, method, seed, options, _ = parse_plan_request(body)
    except BadRequest as exc:
        assert exc.status in (400, 413), (exc.status, exc.message)
        _one_line(exc.message)
    else:  # accepted: the method and seed the body names (or the defaults), parts in bounds
        doc = json.loads(body, parse_float=Decimal)
        assert method == doc.get("method", DEFAULT_METHOD) and method in METHODS
        assert seed == doc.get("seed", DEFAULT_ROOT_SEED) and type(seed) is int
        assert type(assembly) is Assembly and 1 <= len(assembly) <= 64


def _tangram_with(number: str) -> str:
    text = (ROOT / "assemblies" / "unseen" / "tangram.json").read_text()
    return text.replace("[0,0]", f"[{number},0]", 1)


HOSTILE_FILES = [  # (name, text, what the one line must say)
    ("tiny-exponent", _tangram_with("1e-1000000"), "more than 6 digits after the point"),
    ("huge-exponent", _tangram_with("1e10000000"), "out of range"),
    ("huge-integer", _tangram_with("9" * 4200), "out of range"),
    ("nested", "[" * 2_500_000 + "]" * 2_500_000, "nested too deeply"),
    ("png", "\x89PNG\r\n\x1a\n", "is a PNG image"),
]


@pytest.mark.parametrize("command", ["inspect", "plan", "label"])
@pytest.mark.parametrize("name,text,needle", HOSTILE_FILES, ids=[c[0] for c in HOSTILE_FILES])
def test_the_console_script_refuses_a_hostile_file_in_one_line(tmp_path, command, name, text,
                                                               needle):
    path = tmp_path / f"{name}.json"
    path.write_bytes(text.encode("utf-8", "surrogatepass") if name != "png"
                     else text.encode("latin-1"))
    argv = [sys.executable, "-m", "rap.cli", command, str(path)]
    if command == "label":
        argv += ["--out", str(tmp_path / "dataset")]
    env = {k: v for k, v in os.environ.items() if k != "RAP_DEBUG"}
    done = subprocess.run(argv, capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    err = done.stderr.strip()
    _one_line(err)
    assert err.startswith(f"rap-farm: error: {path}: ") and needle in err, err
    assert not (tmp_path / "dataset").exists()  # nothing written
