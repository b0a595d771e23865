"""The experiment's bookkeeping with stand-in backends passed in: cold caches, table, chart,
invariants, method names."""

from __future__ import annotations

import json

import pytest

from rap.dataset import SCHEMA_VERSION, DatasetMeta, write_meta
from rap.errors import InputError, ParameterError
from rap.experiment import run as E
from rap.experiment.report import summarise, write_report
from rap.plan.methods import needs_model
from rap.plan.search.planner import SearchPlanner
from rap.sim.params import SimParams

from tests.plan.cases import ROW3, memory, six
from tests.plan.standins import HashSim, TableCnn, hash_score


def dataset(tmp_path):
    ds = tmp_path / "ds"
    ds.mkdir()
    write_meta(ds, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=3,
                               params=SimParams(trials=10).to_dict(), command="test"))
    return ds


def loader(cnn, loaded=None):
    """A ``load_model`` that gives ``cnn`` for every checkpoint (and records the paths)."""
    return lambda path, **kw: (loaded.append(path) if loaded is not None else None) or cnn


def test_experiment_report_with_standins(tmp_path):
    ds = dataset(tmp_path)
    cnn = TableCnn(lambda op: 0.9 if hash_score(op) >= 0.95 else 0.3)
    rows = E.run_experiment(ds, [six("triangles"), memory(ROW3)], sim_backend=HashSim(), samples=5,
                            log=lambda s: None, load_model=loader(cnn),
                            holdout=lambda *a, **k: tmp_path / "m.pt")
    assert {(r.assembly, r.method) for r in rows} == {(a, m) for a in ("triangles", "row3")
                                                      for m in E.EXPERIMENT_METHODS}
    assert all(r.status == "found" for r in rows)
    # every method starts cold: the sim baseline simulates its own candidates again
    by = {(r.assembly, r.method): r for r in rows}
    assert by[("triangles", "sim")].simulations > 0 and by[("triangles", "optimal")].simulations > 0
    assert by[("triangles", "rap")].extra["model"] == str(tmp_path / "m.pt")
    summary = summarise(rows)
    assert summary["optimal_beaten_by"] == []
    assert summary["rap_decisions"] == sum(by[(a, "rap")].decisions for a in ("triangles", "row3"))
    assert summary["rap_decisions"] >= summary["rap_fallbacks"]
    paths = write_report(rows, tmp_path / "report", "test", {"dataset": "ds"})
    assert [p.name for p in paths] == ["results.md", "results.json", "scores.png"]
    md = paths[0].read_text()
    assert "| triangles |" in md and "| **mean** |" in md and "faster than the sim-only" in md
    doc = json.loads(paths[1].read_text())
    assert doc["notes"] == {"dataset": "ds"} and len(doc["rows"]) == len(rows)
    with pytest.raises(InputError, match="not a rap-farm dataset"):
        E.run_experiment(tmp_path, [], sim_backend=HashSim())


def test_fallback_sweep_methods_and_pareto_table(tmp_path):
    ds = dataset(tmp_path)
    cnn = TableCnn(lambda op: 0.3 * hash_score(op))  # never high: every decision falls back
    seen = []
    deps = dict(load_model=loader(cnn), log=lambda s: None,
                holdout=lambda *a, **k: seen.append(k.get("family")) or tmp_path / "m.pt")
    methods = ["sim", "rap-paper", "rap-k1-o100", "rap-k3-o100", "rap"]
    rows = E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(), methods=methods, **deps)
    by = {r.method: r for r in rows}
    assert by["rap-paper"].robustness == pytest.approx(by["sim"].robustness)  # all: the baseline
    cands = {m: by[m].extra["fallback_candidates"] for m in methods[1:]}
    assert cands["rap-k1-o100"] < cands["rap-k3-o100"] < cands["rap-paper"]
    assert cands["rap"] < cands["rap-paper"]  # the default's fallback stops when good enough
    assert seen == ["reference"]  # the family is passed on, for family hold-out models
    md = write_report(rows, tmp_path / "r", "sweep")[0].read_text()
    assert "## Robustness against planning time" in md and "| rap-k3-o100 |" in md
    with pytest.raises(ParameterError, match="rap-kK"):
        E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(), methods=["rap-kx"], **deps)
    # the confidence threshold: lower -> fewer fallbacks; 100% -> every decision falls back
    rows = E.run_experiment(ds, [six("triangles")], sim_backend=HashSim(),
                            methods=["rap-p100-o100", "rap-p20-o100", "rap-k1-p20"], **deps)
    by.update({r.method: r for r in rows})
    assert by["rap-p100-o100"].robustness == pytest.approx(by["sim"].robustness)
    assert by["rap-p20-o100"].fallbacks < by["rap-paper"].fallbacks == by["rap-p100-o100"].fallbacks
    assert by["rap-k1-p20"].fallbacks == by["rap-p20-o100"].fallbacks
    for bad, why in (("rap-p0", "P must lie in 1..100"), ("rap-p101", "P must lie in 1..100"),
                     ("rap-k0", "K must be >= 1"), ("rap-k2-k3", "rap-kK"), ("rap-q5", "rap-kK"),
                     ("rap-o101", "U must lie in 0..100"), ("bogus", "choose one of rap, sim")):
        with pytest.raises(ParameterError, match=why):
            E.method_planner(bad)


def test_the_planner_factory_is_passed_in(tmp_path):
    """Every plan gets a fresh planner from ``planner(method, samples)``."""
    ds = dataset(tmp_path)
    asked = []

    def planner(method, samples):
        asked.append((method, samples))
        return E.method_planner("sim")

    rows = E.run_experiment(ds, [six("triangles"), memory(ROW3)], sim_backend=HashSim(),
                            methods=["sim", "optimal"], samples=7, log=lambda s: None,
                            planner=planner)
    assert asked == [("sim", 7), ("optimal", 7)] * 3  # checked first, then once per plan
    assert [r.method for r in rows] == ["sim", "optimal"] * 2
    assert rows[0].robustness == rows[1].robustness  # both planned by the sim planner
    assert rows[1].extra.get("dp_evaluations") is None  # not by the optimum's DP


def test_family_holdout_model_is_found(tmp_path):
    (tmp_path / "holdout-family-walls.pt").write_bytes(b"x")
    assert E.holdout_model("ds", "walls-s3", tmp_path, family="walls").name == \
        "holdout-family-walls.pt"
    (tmp_path / "holdout-walls-s3.pt").write_bytes(b"x")
    assert E.holdout_model("ds", "walls-s3", tmp_path, family="walls").name == "holdout-walls-s3.pt"


def test_search_method_names():
    p = E.method_planner("search-w2-s10-b50")
    assert isinstance(p, SearchPlanner) and (p.beam_width, p.simulations, p.max_operations) == (2, 10, 50)
    assert needs_model("search-w2") and needs_model("search") and not needs_model("sim")
    p = E.method_planner("search-s100-t97-o40")
    assert (p.simulations, p.trust, p.optimism) == (100, 0.97, 0.4)
    assert E.method_planner("search").optimism == 0.0
    for bad, why in (("search-x2", "search options are"), ("search-w", "search options are"),
                     ("search-w0", "W must be >= 1"), ("search-o101", "P must lie in 0..100")):
        with pytest.raises(ParameterError, match=why):
            E.method_planner(bad)


def test_one_model_for_every_assembly_is_refused_where_it_was_trained(tmp_path):
    ds = dataset(tmp_path)
    tri, row = six("triangles"), memory(ROW3)
    cnn = TableCnn(lambda op: 0.9 if hash_score(op) >= 0.95 else 0.3)
    cnn.meta = {"assemblies": [{"name": "triangles", "geometry_hash": tri.geometry_hash}]}
    loaded = []
    deps = dict(load_model=loader(cnn, loaded), log=lambda s: None,
                holdout=lambda *a, **k: pytest.fail("no hold-out model"))
    rows = E.run_experiment(ds, [row, six("hexagon")], sim_backend=HashSim(),
                            methods=["rap", "sim"], model=tmp_path / "shipped.pt", **deps)
    assert [r.method for r in rows] == ["rap", "sim"] * 2 and rows[0].status == "found"
    assert rows[0].extra["model"] == str(tmp_path / "shipped.pt")
    assert len(loaded) == 1  # read once: checked and planned with for both assemblies
    given = E.check_held_out(tmp_path / "shipped.pt", [row], loader(cnn, loaded))
    assert given is cnn and len(loaded) == 2
    E.run_experiment(ds, [row], sim_backend=HashSim(), methods=["rap"],
                     model=tmp_path / "shipped.pt", loaded_model=given, **deps)
    assert len(loaded) == 2  # a model the caller read is not read again
    with pytest.raises(ParameterError, match="trained on triangles") as err:
        E.run_experiment(ds, [row, tri], sim_backend=HashSim(), methods=["rap"],
                         model=tmp_path / "shipped.pt", **deps)
    assert err.value.parameter == "model"  # the library names its parameter, not a flag
