"""The close-up view: rendered again from the dataset's geometry, cached, trained on, and rendered
the same way when a planner scores operations."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from model_fixtures import FAST_TRAIN, LEARN_MODEL
from rap.dataset import SCHEMA_VERSION, DatasetMeta, rows_to_table, write_meta, write_shard


@pytest.fixture(scope="module")
def real_dataset(tmp_path_factory):
    """Operations of two reference assemblies with made-up scores, stored as `label` would."""
    from rap.enumerate import enumerate_operations
    from rap.io import load_assembly
    from rap.operation import subset_key
    from rap.render.images import render_pair
    import rap

    root = tmp_path_factory.mktemp("real") / "ds"
    write_meta(root, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=1,
                                 params={"trials": 100}, command="test"))
    data = rap.__file__.rsplit("/", 1)[0] + "/data/assemblies"
    for name in ("hexagon", "rectilinear"):
        a = load_assembly(f"{data}/{name}.json")
        rows = []
        for i, op in enumerate(enumerate_operations(a, "online")[:40]):
            s = 100 if len(op.moving) == 1 else 80
            rows.append({"key": f"{name}-{i}", "assembly": name, "geometry_hash": a.geometry_hash,
                         "subassembly": subset_key(op.subassembly), "moving": subset_key(op.moving),
                         "fixed": subset_key(op.fixed), "direction_x": op.direction[0],
                         "direction_y": op.direction[1], "score": s / 100, "successes": s,
                         "trials": 100, "image": render_pair(a, op), "seed": i,
                         "params": json.dumps({"trials": 100}), "code_version": "test",
                         "node": "test", "family": "reference", "direction_index": 0})
        write_shard(root, rows_to_table(rows))
    return root


def test_crop_channels_are_rendered_once_and_cached(real_dataset, tmp_path, monkeypatch):
    from rap.model.data import RowStore

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr("rap.model.views.PROGRESS_ROWS", 32)
    store = RowStore(real_dataset)
    calls = []
    wide = store.view("pair+crop", lambda done, total: calls.append((done, total)))
    assert calls == [(32, 80), (64, 80), (80, 80)]  # progress while rendering
    assert wide.images.shape == (80, 4, 64, 64) and store.images.shape == (80, 2, 64, 64)
    assert np.array_equal(wide.images[:, :2], store.images)
    assert wide.images[:, 2:].max() == 255  # fixed parts in the close-up
    assert len(list((tmp_path / "cache").glob("*.npy"))) == 1
    again = RowStore(real_dataset).view("pair+crop", lambda *a: calls.append(a))  # from the cache
    assert np.array_equal(again.images, wide.images) and len(calls) == 3


def test_a_crop_model_trains_and_plans_with_the_same_images(real_dataset, tmp_path, monkeypatch):
    from rap.model.predict import Predictor
    from rap.model.train import train
    from rap.plan.fastcnn import load_fast_predictor
    from rap.plan.problem import PlanningProblem
    from rap.plan.scorers import PredictorCnn
    from rap.io import load_assembly
    from rap.sim.params import SimParams
    import rap

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    cfg = replace(LEARN_MODEL, view="pair+crop", in_channels=4, norm="batch", head="binomial")
    res = train(real_dataset, holdout="rectilinear", model_config=cfg,
                config=replace(FAST_TRAIN, epochs=1))
    path = res.save(tmp_path / "crop.pt")
    pred = Predictor.load(path)
    assert pred.view == "pair+crop" and pred.image_shape == (4, 64, 64)
    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + "/data/assemblies/hexagon.json")
    problem = PlanningProblem(a, SimParams(trials=10))
    ops = list(problem.candidates(problem.whole))[:5]
    torch_cnn, fast_cnn = PredictorCnn(pred), PredictorCnn(load_fast_predictor(path))
    assert torch_cnn.images(problem, ops).shape == (5, 4, 64, 64)
    np.testing.assert_allclose(torch_cnn.prob_high(problem, ops), fast_cnn.prob_high(problem, ops),
                               atol=1e-4)
    with pytest.raises(Exception, match="in_channels"):
        replace(LEARN_MODEL, view="pair+crop")  # 2 channels do not fit the view


def test_train_command_takes_the_view(real_dataset, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from rap.cli import app
    from rap.model.predict import Predictor

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "crop.pt"
    res = CliRunner().invoke(app, ["train", str(real_dataset), "--out", str(out), "--holdout",
                                   "rectilinear", "--view", "pair+crop", "--epochs", "1",
                                   "--device", "cpu", "--batch-size", "32"])
    assert res.exit_code == 0, res.output
    assert "view pair+crop" in res.output
    assert "render pair+crop" in res.output and " epoch 1/1" in res.output  # both bars
    pred = Predictor.load(out)
    assert pred.view == "pair+crop" and pred.image_shape == (4, 64, 64)
