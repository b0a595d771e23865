"""Labelling at any size: seeded samples of huge operation spaces with bounded driver memory,
failures isolated per assembly."""

from __future__ import annotations

import json

import pytest

from rap.assembly import assembly_to_json
from rap.dataset import open_dataset
from rap.geometry.families.simple import grid

from tests.farm.conftest import ASSEMBLIES, FAKE, REAL

pytestmark = pytest.mark.ray


def rss_mib() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


@pytest.fixture(scope="module")
def grid10(tmp_path_factory):
    p = tmp_path_factory.mktemp("asm") / "grid10.json"
    p.write_text(json.dumps(assembly_to_json(grid(10))))
    return p


def test_space_of_the_100_part_grid_exceeds_a_million(grid10):
    from rap.io import load_assembly
    from rap.enumerate import count_operations

    assert count_operations(load_assembly(grid10), budget=1_000_000) is None


def label(out, assemblies, seed, **kw):
    from rap.farm.driver import LabelConfig, run_label

    peak = [rss_mib()]
    cfg = LabelConfig(assemblies=tuple(str(a) for a in assemblies), out=str(out), trials=2,
                      seed=seed, max_ops_per_assembly=100, backend=REAL, progress=False,
                      flush_rows=32, workers=2, **kw)
    s = run_label(cfg, on_batch=lambda _: peak.append(rss_mib()))
    return s, max(peak) - peak[0]


def rows(out):
    t = open_dataset(out).to_table(columns=["key", "moving", "fixed", "direction_x", "direction_y",
                                            "score"])
    return sorted(t.to_pylist(), key=lambda r: r["key"])


def test_seeded_sample_of_a_huge_space_bounded_memory_no_duplicates(ray_local, grid10, tmp_path):
    s, growth = label(tmp_path / "a", [grid10], seed=5, directions_per_range=2)
    assert s.labelled == 100 and not s.failed and s.first_shard_s is not None
    a = rows(tmp_path / "a")
    assert len(a) == 100 and len({r["key"] for r in a}) == 100
    assert len({(r["moving"], r["fixed"], r["direction_x"], r["direction_y"]) for r in a}) == 100
    assert growth < 256, f"driver RSS grew by {growth:.0f} MiB"
    s2, _ = label(tmp_path / "b", [grid10], seed=5, directions_per_range=2)
    assert rows(tmp_path / "b") == a  # the same seed: the same sample, the same labels
    label(tmp_path / "c", [grid10], seed=6, directions_per_range=2)
    assert {r["key"] for r in rows(tmp_path / "c")}.isdisjoint({r["key"] for r in a})


def test_a_failing_assembly_keeps_the_others(ray_local, tmp_path, capsys, monkeypatch):
    import dataclasses

    import rap.farm.driver as driver
    from rap.cli import main
    from rap.farm.actors import Backend

    boom = tmp_path / "boom.json"
    doc = json.loads((ASSEMBLIES / "hexagon.json").read_text())
    doc["name"] = "boom"
    boom.write_text(json.dumps(doc))
    failing = Backend(simulate="tests.farm.standin:simulate_or_fail", render=FAKE.render)
    run = driver.run_label
    monkeypatch.setattr(driver, "run_label",
                        lambda c, plan=None, **kw: run(dataclasses.replace(c, backend=failing),
                                                       plan, **kw))
    out = tmp_path / "ds"
    argv = ["label", str(ASSEMBLIES / "grid.json"), str(boom), str(ASSEMBLIES / "triangles.json"),
            "--out", str(out), "--max-ops-per-assembly", "20", "--trials", "2", "--quiet"]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    cap = capsys.readouterr()
    assert exc.value.code == 3
    err = cap.err.strip().splitlines()[-1]
    assert err.startswith("rap-farm: error: labelling failed for 1 of 3 assemblies (boom)"), err
    assert "FAILED       boom: simulation of a batch of boom failed" in cap.out
    per = {}
    for r in open_dataset(out).to_table(columns=["assembly"]).column("assembly").to_pylist():
        per[r] = per.get(r, 0) + 1
    assert per.get("grid") == 20 and per.get("triangles") == 20 and "boom" not in per
