"""The close-up view: rendered again from the dataset's geometry, cached, trained on, and rendered
the same way when a planner scores operations."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.model.model_fixtures import FAST_TRAIN, LEARN_MODEL


def test_crop_channels_are_rendered_once_and_cached(real_dataset, tmp_path, monkeypatch):
    from rap.model.data.rows import RowStore

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr("rap.model.data.views.PROGRESS_ROWS", 32)
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
    from rap.model.inference.torch_engine import TorchPredictor
    from rap.model.training.train import train
    from rap.model.inference.numpy_engine import load_numpy_predictor
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.io import load_assembly
    from rap.sim.params import SimParams
    import rap

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    cfg = replace(LEARN_MODEL, view="pair+crop", in_channels=4, norm="batch", head="binomial")
    res = train(real_dataset, holdout="rectilinear", model_config=cfg,
                config=replace(FAST_TRAIN, epochs=1))
    path = res.save(tmp_path / "crop.pt")
    pred = TorchPredictor.load(path)
    assert pred.view == "pair+crop" and pred.image_shape == (4, 64, 64)
    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + "/data/assemblies/hexagon.json")
    problem = PlanningProblem(a, SimParams(trials=10))
    ops = list(problem.candidates(problem.whole))[:5]
    torch_cnn, fast_cnn = OperationPredictor(pred), OperationPredictor(load_numpy_predictor(path))
    assert torch_cnn.images(problem, ops).shape == (5, 4, 64, 64)
    np.testing.assert_allclose(torch_cnn.prob_high(problem, ops), fast_cnn.prob_high(problem, ops),
                               atol=1e-4)
    with pytest.raises(ValueError, match=r"^ModelConfig: view 'pair\+crop' has 4 channels, "
                                         r"in_channels is 2$"):
        replace(LEARN_MODEL, view="pair+crop")  # 2 channels do not fit the view


def test_train_command_takes_the_view(real_dataset, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from rap.cli import app
    from rap.model.inference.torch_engine import TorchPredictor

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "crop.pt"
    res = CliRunner().invoke(app, ["train", str(real_dataset), "--out", str(out), "--holdout",
                                   "rectilinear", "--view", "pair+crop", "--epochs", "1",
                                   "--device", "cpu", "--batch-size", "32"])
    assert res.exit_code == 0, res.output
    assert "view pair+crop" in res.output
    assert "render pair+crop" in res.output and " epoch 1/1" in res.output  # both bars
    pred = TorchPredictor.load(out)
    assert pred.view == "pair+crop" and pred.image_shape == (4, 64, 64)
