"""``rap-farm plan`` end to end in a subprocess (no Ray): output file, picture, exit statuses."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.plan.cases import FRAMED_HOLE, ROOT, ROW3, write


def run(*args, tmp_path):
    env = dict(os.environ, RAP_CACHE=str(tmp_path / "cache.json"), PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", "from rap.cli import main; main()", "plan", *map(str, args)],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)


def test_interlocked_assembly_exits_1_and_names_the_parts(tmp_path):
    src = write(FRAMED_HOLE, tmp_path / "framed.json")
    out = tmp_path / "plan.json"
    p = run(src, "--method", "sim", "--no-ray", "--trials", "8", "--out", out, tmp_path=tmp_path)
    assert p.returncode == 1, p.stderr
    assert "frame" in p.stderr and "plug" in p.stderr and "interlocked" in p.stderr
    assert "Traceback" not in p.stderr
    doc = json.loads(out.read_text())
    assert doc["feasible"] is False and doc["interlocked"] == ["frame", "plug"]


def test_plan_writes_the_documented_json_and_a_storyboard(tmp_path):
    src = write(ROW3, tmp_path / "row3.json")
    out, pic = tmp_path / "plan.json", tmp_path / "plan.png"
    p = run(src, "--method", "sim", "--no-ray", "--trials", "8", "--out", out, "--picture", pic,
            tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "robustness R" in p.stdout and "sim" in p.stdout
    doc = json.loads(out.read_text())
    assert {"assembly", "method", "feasible", "robustness", "steps", "seconds"} <= set(doc)
    assert doc["assembly"] == "row3" and doc["method"] == "sim" and doc["feasible"] is True
    assert len(doc["steps"]) == 2
    for s in doc["steps"]:
        assert {"moving", "fixed", "insertion", "score", "source", "confidence"} <= set(s)
        assert s["source"] == "sim" and s["confidence"] is None and 0 <= s["score"] <= 1
    r = 1.0
    for s in doc["steps"]:
        r *= s["score"]
    assert doc["robustness"] == pytest.approx(r)
    assert pic.stat().st_size > 1000
    assert (tmp_path / "cache.json").is_file()


@pytest.mark.parametrize("args,needle", [
    (("missing.json",), "no such file"),
    (("{row3}", "--method", "best"), "--method"),
    (("{row3}", "--picture", "x.gif"), "--picture"),
    (("{row3}", "--model", "nope.pt"), "nope.pt"),
    (("{row3}", "--perturbed-candidate", "--no-rollouts"), "--perturbed-candidate"),
    (("{row3}", "--perturbed-candidate", "--method", "sim"), "--perturbed-candidate"),
])
def test_invalid_input_exits_2_with_one_line(tmp_path, args, needle):
    src = write(ROW3, tmp_path / "row3.json")
    args = [a.replace("{row3}", str(src)) for a in args]
    p = run(*args, "--no-ray", tmp_path=tmp_path)
    assert p.returncode == 2, (p.stdout, p.stderr)
    assert needle in p.stderr and len(p.stderr.strip().splitlines()) == 1


def test_without_a_model_rap_says_so_and_uses_the_simulator(tmp_path):
    from rap.commands.plan import default_model_path

    if default_model_path().is_file():
        pytest.skip("a default model is shipped")
    src = write(ROW3, tmp_path / "row3.json")
    p = run(src, "--no-ray", "--trials", "8", "--out", tmp_path / "p.json", tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "default model" in p.stderr and "--method sim" in p.stderr
    assert json.loads((tmp_path / "p.json").read_text())["method"] == "sim"


def test_search_simulates_the_untrusted_steps_of_its_plan(tmp_path):
    src = write(ROW3, tmp_path / "row3.json")
    out = tmp_path / "plan.json"
    # --gap 0: no phase 2, which chooses by the bounds alone and simulates trusted steps too
    p = run(src, "--method", "search", "--simulations", "50", "--trust", "0.9", "--gap", "0",
            "--trials", "8", "--out", out, tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    steps = json.loads(out.read_text())["steps"]
    assert steps and all((s["source"] == "sim") != (s["predicted"] >= 0.9) for s in steps)
    for value in ("1.5", "0"):
        bad = run(src, "--trust", value, tmp_path=tmp_path)
        assert bad.returncode == 2 and "--trust" in bad.stderr and "Traceback" not in bad.stderr
    bad = run(src, "--optimism", "1.5", tmp_path=tmp_path)
    assert bad.returncode == 2 and "--optimism" in bad.stderr and "Traceback" not in bad.stderr


def test_full_optimism_plans_every_step_from_simulations(tmp_path):
    src = write(ROW3, tmp_path / "row3.json")
    out = tmp_path / "plan.json"
    p = run(src, "--method", "search", "--simulations", "1000", "--optimism", "1", "--trials",
            "8", "--out", out, tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    assert all(s["source"] == "sim" for s in json.loads(out.read_text())["steps"])


def test_rap_high_probability_decides_what_counts_as_high(tmp_path):
    src = write(ROW3, tmp_path / "row3.json")
    docs = {}
    for p_high in ("1.0", "0.01"):  # nothing is high: every decision falls back; everything is
        out = tmp_path / f"plan-{p_high}.json"
        p = run(src, "--method", "rap", "--high-probability", p_high, "--trials", "8", "--out", out,
                "--no-cache", tmp_path=tmp_path)
        assert p.returncode == 0, p.stderr
        docs[p_high] = json.loads(out.read_text())["steps"]
    assert all(s["source"] == "sim" for s in docs["1.0"])
    assert all(s["source"] == "model" for s in docs["0.01"])
    bad = run(src, "--method", "rap", "--high-probability", "0", tmp_path=tmp_path)
    assert bad.returncode == 2 and "--high-probability" in bad.stderr
    assert "Traceback" not in bad.stderr


def test_optimism_without_simulations_warns(tmp_path):
    src = write(ROW3, tmp_path / "row3.json")
    p = run(src, "--method", "search", "--optimism", "0.5", "--trials", "8", tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "without --simulations N they change nothing" in " ".join(p.stderr.split())
