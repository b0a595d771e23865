"""The descriptor network (rap.model.inference.descriptor_model): file round trip, head, refusal."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rap.model.inference.descriptor_model import DescriptorModel
from rap.model.inference.numpy_engine import binomial_tail


def _model(seed: int = 0) -> DescriptorModel:
    rng = np.random.default_rng(seed)
    layers = [(rng.normal(size=(12, 8)), rng.normal(size=8)), (rng.normal(size=(8, 1)), rng.normal(size=1))]
    return DescriptorModel(rng.normal(size=12), 1 + rng.random(12), layers,
                           {"threshold": 0.95, "trials": 100, "temperature": 1.3, "band": [0.3, 0.7]})


def test_round_trip(tmp_path):
    m = _model()
    path = m.save(tmp_path / "m.scorer.npz")
    back = DescriptorModel.load(path)
    x = np.random.default_rng(1).normal(size=(7, 12)).astype(np.float32)
    np.testing.assert_array_equal(back.logits(x), m.logits(x))
    assert back.meta["band"] == [0.3, 0.7] and back.temperature == 1.3
    assert DescriptorModel.read_meta(path) == back.meta


def test_head_is_the_binomial_head_with_temperature():
    m = _model()
    x = np.random.default_rng(2).normal(size=(5, 12))
    prob, expected = m.prob_high_and_expected(x)
    p = 1 / (1 + np.exp(-m.logits(x) / 1.3))
    np.testing.assert_allclose(expected, p)
    np.testing.assert_allclose(prob, binomial_tail(p, 100, 95))
    np.testing.assert_allclose(m.prob_high(x), prob)
    np.testing.assert_allclose(m.expected_score(x), expected)


def test_trees_round_trip(tmp_path):
    lightgbm = pytest.importorskip("lightgbm")
    rng = np.random.default_rng(3)
    x = rng.normal(size=(200, 12))
    rate = 1 / (1 + np.exp(-x[:, 0]))
    booster = lightgbm.train({"objective": "cross_entropy", "num_leaves": 4, "verbose": -1,
                              "seed": 0, "deterministic": True, "num_threads": 1},
                             lightgbm.Dataset(x, label=rate), 5)
    m = DescriptorModel(None, None, [], {"threshold": 0.95, "trials": 100, "temperature": 0.9},
                        booster=booster.model_to_string())
    back = DescriptorModel.load(m.save(tmp_path / "t.scorer.npz"))
    assert back.meta["kind"] == "gbt"
    np.testing.assert_allclose(back.logits(x[:7]), booster.predict(x[:7], raw_score=True))
    np.testing.assert_allclose(back.expected_score(x[:7]),
                               1 / (1 + np.exp(-booster.predict(x[:7], raw_score=True) / 0.9)))
    assert back.logits(x[:0]).shape == (0,)


def test_refuses_another_file(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, meta=np.array(json.dumps({"format": "something else"})), mean=np.zeros(12))
    with pytest.raises(ValueError, match="not a"):
        DescriptorModel.load(path)
    with pytest.raises(ValueError, match="not a"):
        DescriptorModel.read_meta(path)
