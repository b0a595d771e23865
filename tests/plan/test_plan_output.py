"""What ``rap-farm plan`` writes for a controller: the JSON keys, ``--csv`` (read with pandas),
file modes under the umask, and progress that never reaches machine-read output."""

from __future__ import annotations

import io
import json
import os
import stat
import subprocess
import sys

import pandas as pd
import pytest

from rap.files import write_text_atomic
from rap.plan.report.poses import CSV_COLUMNS, tidy

from tests.plan.cases import FRAMED_HOLE, ROOT, ROW3, write

TOP_KEYS = ["assembly", "method", "feasible", "units", "robustness", "robustness_interval",
            "confidence_level", "trials", "steps", "seconds"]
STEP_KEYS = ["moving", "fixed", "insertion", "score", "score_interval", "source", "confidence",
             "reason", "robot"]
ROBOT_KEYS = ["start", "approach", "goal", "travel", "clearance", "approach_distance", "centroid"]


def run(*args, tmp_path, umask=0o022):
    env = dict(os.environ, RAP_CACHE=str(tmp_path / "cache.json"), PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", "from rap.cli import main; main()", "plan",
                           *map(str, args)], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300, preexec_fn=lambda: os.umask(umask))


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("planned")
    src = write(dict(ROW3, units="mm"), tmp / "row3.json")
    out, csv = tmp / "plan.json", tmp / "plan.csv"
    p = run(src, "--method", "sim", "--no-ray", "--trials", "8", "--workers", "1", "--out", out,
            "--csv", csv, tmp_path=tmp)
    assert p.returncode == 0, p.stderr
    return p, json.loads(out.read_text()), out, csv


def test_the_json_states_units_intervals_reasons_and_robot_moves(planned):
    _, doc, _, _ = planned
    assert [k for k in doc if k in TOP_KEYS] == TOP_KEYS  # (other keys may follow: e.g. a bound)
    assert doc["units"] == "mm" and doc["trials"] == 8 and doc["confidence_level"] == 0.95
    lo, hi = doc["robustness_interval"]
    assert 0 <= lo <= doc["robustness"] <= hi <= 1
    for s in doc["steps"]:
        assert [k for k in s if k in STEP_KEYS] == STEP_KEYS
        assert list(s["robot"]) == ROBOT_KEYS
        assert s["score_interval"][0] <= s["score"] <= s["score_interval"][1]
        assert abs(s["insertion"][0] ** 2 + s["insertion"][1] ** 2 - 1) < 1e-12
        assert s["robot"]["goal"] == [0.0, 0.0] and s["robot"]["travel"] > 0
        assert "mm" in s["reason"] or "°" in s["reason"]


def test_the_json_and_the_table_weigh_failures_and_attempts_beside_r(planned):
    p, doc, _, _ = planned
    scores = [s["score"] for s in doc["steps"]]
    assert doc["expected_failures"] == pytest.approx(sum(1 - r for r in scores))
    assert doc["expected_attempts"] == pytest.approx(sum(1 / r for r in scores))
    assert (f"expected failed steps: {doc['expected_failures']:.2f} of 2; expected attempts "
            f"with retries: {doc['expected_attempts']:.2f}") in p.stdout


def test_the_csv_has_one_row_a_step_and_agrees_with_the_json(planned):
    _, doc, _, csv = planned
    table = pd.read_csv(csv)
    assert list(table.columns) == list(CSV_COLUMNS)
    assert list(table["step"]) == list(range(1, len(doc["steps"]) + 1))
    for (_, row), s in zip(table.iterrows(), doc["steps"]):
        assert row["moving"].split(",") == s["moving"] and row["fixed"].split(",") == s["fixed"]
        # the CSV's numbers are the JSON's rounded to 12 decimals (execution.tidy)
        assert (row["insertion_x"], row["insertion_y"]) == tuple(map(tidy, s["insertion"]))
        assert (row["start_x"], row["start_y"]) == tuple(map(tidy, s["robot"]["start"]))
        assert (row["approach_x"], row["approach_y"]) == tuple(map(tidy, s["robot"]["approach"]))
        assert (row["goal_x"], row["goal_y"], row["travel"]) == (0.0, 0.0,
                                                                 tidy(s["robot"]["travel"]))
        assert ((row["centroid_x"], row["centroid_y"])
                == tuple(map(tidy, s["robot"]["centroid"]["goal"])))
        assert (row["score"], row["score_low"], row["score_high"]) == (s["score"],
                                                                      *s["score_interval"])
        assert row["units"] == "mm" and row["source"] == s["source"]
        assert row["reason"] == s["reason"]


def test_plan_files_are_readable_by_others_under_umask_022(planned):
    _, _, out, csv = planned
    for path in (out, csv):
        assert stat.S_IMODE(path.stat().st_mode) == 0o644
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".tmp-")]


def test_progress_never_reaches_the_table_or_a_piped_stderr(planned):
    p, _, _, _ = planned
    assert "robustness R" in p.stdout and "95% CI" in p.stdout and "insertion" in p.stdout
    for spinner in "⠋⠙⠹⠸⠼⠴⠦⠧⠇⠏":
        assert spinner not in p.stdout + p.stderr
    assert "planning row3" not in p.stderr


def test_an_interlocked_assembly_writes_no_csv_and_a_bad_suffix_is_one_line(tmp_path):
    src = write(FRAMED_HOLE, tmp_path / "framed.json")
    p = run(src, "--method", "sim", "--no-ray", "--trials", "4", "--csv", tmp_path / "p.csv",
            tmp_path=tmp_path)
    assert p.returncode == 1 and not (tmp_path / "p.csv").exists()
    p = run(src, "--no-ray", "--csv", tmp_path / "p.txt", tmp_path=tmp_path)
    assert p.returncode == 2 and "--csv" in p.stderr and len(p.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("umask,mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_atomic_text_files_take_the_umasks_mode(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        path = write_text_atomic(tmp_path / "sub" / "f.csv", "a,b\n1,2\n", newline="")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == mode and path.read_text() == "a,b\n1,2\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["f.csv"]


def test_the_progress_line_shows_the_scorers_counters_on_a_terminal():
    from rich.console import Console

    from rap.commands._progress import activity
    from rap.plan.scoring.scorer import ScorerStats

    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=120)
    with activity("planning wall22", console, enabled=True) as progress:
        progress.scorer_progress(ScorerStats(sim_run=12, cnn_ops=340, cache_hits=3), running=8)
        progress._progress.refresh()
    text = buf.getvalue()
    assert "planning wall22" in text and "340 operations scored by the model" in text
    assert "12 simulated" in text and "simulating 8 now" in text
    assert not activity("x", Console(file=io.StringIO())).enabled  # not a terminal: nothing


def test_the_scorer_reports_each_batch_before_and_after_it():
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.scorer import Scorer
    from rap.sim.params import SimParams

    from tests.plan.cases import memory
    from tests.plan.standins import HashSim

    seen = []
    problem = PlanningProblem(memory(ROW3), SimParams(trials=20))
    scorer = Scorer(HashSim(), on_progress=lambda st, running: seen.append((st.sim_run, running)))
    ops = list(problem.candidates(problem.whole))
    scorer.scores(problem, ops)
    scorer.scores(problem, ops)  # all cached: one report, nothing running
    assert seen == [(0, len(ops)), (len(ops), 0), (len(ops), 0)]


def test_a_sheet_of_parts_lying_apart_prints_free_steps_and_a_wall_time_with_reading(tmp_path):
    """Free steps print as such, nothing is simulated, and the wall time counts the reading."""
    from tests.plan.test_front_door import APART

    out = tmp_path / "plan.json"
    p = run(write(APART, tmp_path / "apart.json"), "--method", "sim", "--no-ray", "--trials", "8",
            "--workers", "1", "--out", out, tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    doc = json.loads(out.read_text())
    assert doc["robustness"] == 1.0 and doc["robustness_interval"] == [1.0, 1.0]
    assert {s["source"] for s in doc["steps"]} == {"free"}
    assert {s["reason"] for s in doc["steps"]} == {"free: no contact"}
    assert "0 simulations run" in p.stdout and "free: no contact" in p.stdout
    assert "wall" in p.stdout and "(reading the assembly included)" in p.stdout
