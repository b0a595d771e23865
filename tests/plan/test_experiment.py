"""The experiment's bookkeeping with stand-in backends: cold caches, table, chart, invariants."""

from __future__ import annotations

import pytest

from rap.dataset import SCHEMA_VERSION, DatasetMeta, write_meta
from rap.plan import experiment as E
from rap.sim.params import SimParams

from tests.plan.cases import ROW3, memory, six
from tests.plan.standins import HashSim, TableCnn, hash_score


def test_experiment_report_with_standins(tmp_path, monkeypatch):
    ds = tmp_path / "ds"
    ds.mkdir()
    write_meta(ds, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=3,
                               params=SimParams(trials=10).to_dict(), command="test"))
    cnn = TableCnn(lambda op: 0.9 if hash_score(op) >= 0.95 else 0.3)
    monkeypatch.setattr(E, "holdout_model", lambda *a, **k: tmp_path / "m.pt")
    monkeypatch.setattr(E.PredictorCnn, "load", classmethod(lambda cls, path, device="cpu": cnn))
    sim = HashSim()
    rows = E.run_experiment(ds, [six("triangles"), memory(ROW3)], sim_backend=sim, samples=5,
                            log=lambda s: None)
    assert {(r.assembly, r.method) for r in rows} == {(a, m) for a in ("triangles", "row3")
                                                      for m in E.EXPERIMENT_METHODS}
    assert all(r.status == "found" for r in rows)
    # every method starts cold: the sim baseline simulates its own candidates again
    by = {(r.assembly, r.method): r for r in rows}
    assert by[("triangles", "sim")].simulations > 0 and by[("triangles", "optimal")].simulations > 0
    summary = E.summarise(rows)
    assert summary["optimal_beaten_by"] == []
    assert summary["rap_decisions"] >= summary["rap_fallbacks"] >= 0
    paths = E.write_report(rows, tmp_path / "report", "test", {"dataset": "ds"})
    assert [p.name for p in paths] == ["results.md", "results.json", "scores.png"]
    md = paths[0].read_text()
    assert "| triangles |" in md and "| **mean** |" in md and "faster than the sim-only" in md
    with pytest.raises(Exception):
        E.run_experiment(tmp_path, [], sim_backend=sim)  # not a dataset


def test_fallback_sweep_methods_and_pareto_table(tmp_path, monkeypatch):
    ds = tmp_path / "ds"
    ds.mkdir()
    write_meta(ds, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=3,
                               params=SimParams(trials=10).to_dict(), command="test"))
    cnn = TableCnn(lambda op: 0.3 * hash_score(op))  # never high: every decision falls back
    seen = []
    monkeypatch.setattr(E, "holdout_model",
                        lambda *a, **k: seen.append(k.get("family")) or tmp_path / "m.pt")
    monkeypatch.setattr(E.PredictorCnn, "load", classmethod(lambda cls, path, device="cpu": cnn))
    methods = ["sim", "rap-paper", "rap-k1-o100", "rap-k3-o100", "rap"]
    rows = E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(), methods=methods,
                            log=lambda s: None)
    by = {r.method: r for r in rows}
    assert by["rap-paper"].robustness == pytest.approx(by["sim"].robustness)  # all: the baseline
    cands = {m: by[m].extra["fallback_candidates"] for m in methods[1:]}
    assert cands["rap-k1-o100"] < cands["rap-k3-o100"] < cands["rap-paper"]
    assert cands["rap"] < cands["rap-paper"]  # the default's fallback stops when good enough
    assert seen == ["reference"]  # the family is passed on, for family hold-out models
    md = E.write_report(rows, tmp_path / "r", "sweep")[0].read_text()
    assert "## Robustness against planning time" in md and "| rap-k3-o100 |" in md
    with pytest.raises(Exception, match="rap-kK"):
        E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(), methods=["rap-kx"])
    # the confidence threshold: lower -> fewer fallbacks; 100% -> every decision falls back
    rows = E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(),
                            methods=["rap-p100-o100", "rap-p20-o100", "rap-k1-p20"],
                            log=lambda s: None)
    by.update({r.method: r for r in rows})
    assert by["rap-p100-o100"].robustness == pytest.approx(by["sim"].robustness)
    assert by["rap-p20-o100"].fallbacks < by["rap-paper"].fallbacks == by["rap-p100-o100"].fallbacks
    assert by["rap-k1-p20"].fallbacks == by["rap-p20-o100"].fallbacks
    for bad, why in (("rap-p0", "1..100"), ("rap-p101", "1..100"), ("rap-k0", ">= 1"),
                     ("rap-k2-k3", "rap-kK"), ("rap-q5", "rap-kK"), ("rap-o101", "0..100")):
        with pytest.raises(Exception, match=why):
            E.method_planner(bad)


def test_family_holdout_model_is_found(tmp_path):
    (tmp_path / "holdout-family-walls.pt").write_bytes(b"x")
    assert E.holdout_model("ds", "walls-s3", tmp_path, family="walls").name == \
        "holdout-family-walls.pt"
    (tmp_path / "holdout-walls-s3.pt").write_bytes(b"x")
    assert E.holdout_model("ds", "walls-s3", tmp_path, family="walls").name == "holdout-walls-s3.pt"


def test_search_method_names():
    from rap.plan.search import SearchPlanner

    p = E.method_planner("search-w2-s10-b50")
    assert isinstance(p, SearchPlanner) and (p.beam_width, p.simulations, p.max_operations) == (2, 10, 50)
    assert E.uses_cnn("search-w2") and E.uses_cnn("search") and not E.uses_cnn("sim")
    p = E.method_planner("search-s100-t97-o40")
    assert (p.simulations, p.trust, p.optimism) == (100, 0.97, 0.4)
    assert E.method_planner("search").optimism == 0.0
    for bad in ("search-x2", "search-w", "search-w0", "search-o101"):
        with pytest.raises(Exception):
            E.method_planner(bad)


def test_one_model_for_every_assembly_is_refused_where_it_was_trained(tmp_path, monkeypatch):
    ds = tmp_path / "ds"
    ds.mkdir()
    write_meta(ds, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=3,
                               params=SimParams(trials=10).to_dict(), command="test"))
    tri, row = six("triangles"), memory(ROW3)
    cnn = TableCnn(lambda op: 0.9 if hash_score(op) >= 0.95 else 0.3)
    cnn.meta = {"assemblies": [{"name": "triangles", "geometry_hash": tri.geometry_hash}]}
    loaded = []
    monkeypatch.setattr(E, "holdout_model", lambda *a, **k: pytest.fail("no hold-out model"))
    monkeypatch.setattr(E.PredictorCnn, "load",
                        classmethod(lambda cls, path, **kw: loaded.append(path) or cnn))
    rows = E.run_experiment(ds, [row, six("hexagon")], sim_backend=HashSim(),
                            methods=["rap", "sim"], log=lambda s: None,
                            model=tmp_path / "shipped.pt")
    assert [r.method for r in rows] == ["rap", "sim"] * 2 and rows[0].status == "found"
    assert rows[0].extra["model"] == str(tmp_path / "shipped.pt")
    assert len(loaded) == 2  # read once for the check, loaded once for both assemblies
    with pytest.raises(E.InputError, match="trained on triangles"):
        E.run_experiment(ds, [row, tri], sim_backend=HashSim(), methods=["rap"],
                         log=lambda s: None, model=tmp_path / "shipped.pt")
