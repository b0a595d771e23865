"""The newcomer's main job, `rap-farm demo`, end to end at a tiny scale in a subprocess."""

import json
import os
import secrets
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.ray
@pytest.mark.slow
def test_demo_labels_trains_plans_and_says_where_outputs_went(tmp_path):
    out = tmp_path / "demo"
    env = {**os.environ, "RAY_AUTH_TOKEN": secrets.token_hex(32), "RAY_USAGE_STATS_ENABLED": "0",
           "RAP_CACHE": str(tmp_path / "cache.json")}
    proc = subprocess.run(
        [sys.executable, "-m", "rap.cli", "demo", "--out", str(out), "--ops", "6", "--trials", "4",
         "--epochs", "1", "--workers", "2", "--assemblies", str(ROOT / "assemblies")],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("model.pt", "plan.json", "storyboard.png", "plan.md"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
        assert str(out / name) in proc.stdout.replace("\n", "") or name in proc.stdout
    plan = json.loads((out / "plan.json").read_text())
    assert plan["assembly"] == "hexagon" and plan["method"] == "rap" and plan["feasible"] is True
    assert len(plan["steps"]) == 6  # hexagon: 7 parts
    product = 1.0
    for step in plan["steps"]:
        product *= step["score"]
        assert step["source"] in ("cnn", "sim")
    assert plan["robustness"] == pytest.approx(product)
    rows = sum(1 for _ in (out / "dataset").glob("*/part-*.parquet"))
    assert rows >= 6  # one directory per assembly, shards committed
