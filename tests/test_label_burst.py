"""scripts/label_burst.py labels exactly what `rap-farm label` would, into the same dataset format."""

import subprocess
import sys
from pathlib import Path

from rap.dataset import open_dataset, read_meta
from rap.labelling.selection import LabelConfig, LabelSummary, iter_jobs, prepare

ROOT = Path(__file__).resolve().parents[1]


def test_burst_rows_are_the_farms(tmp_path):
    out = tmp_path / "ds"
    args = [sys.executable, str(ROOT / "scripts" / "label_burst.py"), str(ROOT / "assemblies" / "hexagon.json"),
            "--out", str(out), "--processes", "2", "--trials", "4", "--seed", "7",
            "--max-ops-per-assembly", "6", "--directions-per-range", "2"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    t = open_dataset(out).to_table()
    assert t.num_rows == 6 and len(set(t.column("key").to_pylist())) == 6
    assert set(t.column("trials").to_pylist()) == {4}
    assert read_meta(out).root_seed == 7
    # the farm's selection over the same options finds nothing left to label ...
    cfg = LabelConfig(assemblies=(str(ROOT / "assemblies" / "hexagon.json"),), out=str(out), trials=4,
                      seed=7, max_ops_per_assembly=6, directions_per_range=2, progress=False)
    plan = prepare(cfg)
    summary = LabelSummary(out=str(out))
    assert list(iter_jobs(plan, summary, lambda k: None)) == [] and summary.existing == 6
    plan.release()  # the plan holds the dataset's one-writer lock until then
    # ... and a second burst adds nothing
    again = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and "labelled 0 rows" in again.stdout
    assert open_dataset(out).count_rows() == 6
