import numpy as np
import pytest

from tests.model.model_fixtures import FAST_TRAIN, TINY_MODEL, synthetic_image
from rap.errors import ParameterError
from rap.model.inference.torch_engine import TorchPredictor, resolve_device
from rap.model.training.train import train


@pytest.fixture(scope="module")
def predictor(tiny_dataset, tmp_path_factory):
    path = train(tiny_dataset, holdout="beta", model_config=TINY_MODEL, config=FAST_TRAIN).save(
        tmp_path_factory.mktemp("pred") / "m.pt")
    return TorchPredictor.load(path, device="cpu")


def test_prob_high_one_batch(predictor):
    rng = np.random.default_rng(0)
    images = np.stack([synthetic_image(rng, i % 2 == 0, 10, 40) for i in range(7)])
    p = predictor.prob_high(images)
    assert p.shape == (7,) and p.dtype == np.float64 and ((0 <= p) & (p <= 1)).all()
    np.testing.assert_allclose(predictor.prob_high(images[:3]), p[:3], atol=1e-6)
    assert np.array_equal(predictor.is_high(images), p >= 0.5)
    assert predictor.prob_high(np.zeros((0, 2, 64, 64), np.uint8)).shape == (0,)
    with pytest.raises(ValueError):
        predictor.prob_high(images.astype(np.float32))
    with pytest.raises(ValueError):
        predictor.prob_high(images[:, :1])


def test_training_data_metadata(predictor):
    assert predictor.trained_on("geom-alpha") and not predictor.trained_on("geom-beta")
    rng = np.random.default_rng(1)
    alike = np.stack([synthetic_image(rng, i % 3 == 0, 10, 40) for i in range(30)])
    far = np.full((30, 2, 64, 64), 255, np.uint8)
    near, away = predictor.shift(alike), predictor.shift(far)
    assert max(map(abs, near["foreground_z"])) < 2 < min(map(abs, away["foreground_z"]))
    assert near["coarse_difference"] < away["coarse_difference"]


def test_cpu_batches_are_chunked_without_changing_outputs(predictor, monkeypatch):
    import rap.model.inference.torch_engine as predict

    rng = np.random.default_rng(1)
    images = np.stack([synthetic_image(rng, i % 2 == 0, 10, 40) for i in range(11)])
    whole = predictor.outputs(images)
    monkeypatch.setattr(predict, "CPU_CHUNK", 4)
    calls = []
    forward = predictor.model.forward
    monkeypatch.setattr(predictor.model, "forward",
                        lambda x, d=None: calls.append(len(x)) or forward(x, d))
    np.testing.assert_allclose(predictor.outputs(images), whole, atol=1e-5)
    assert calls == [4, 4, 3]


def test_devices_it_cannot_use_name_the_parameter(monkeypatch):
    """The library speaks of ``device`` (``rap-farm train`` and ``score`` of --device)."""
    with pytest.raises(ParameterError) as err:
        resolve_device("tpu")
    assert (err.value.parameter, str(err.value)) == (
        "device", "device 'tpu': unknown device (auto, cpu or cuda)")
    monkeypatch.setattr("torch.cuda.is_available", lambda: False)
    with pytest.raises(ParameterError) as err:
        resolve_device("cuda")
    assert (err.value.parameter, str(err.value)) == (
        "device", "device cuda: no CUDA device is available")
    assert resolve_device("auto").type == "cpu"
