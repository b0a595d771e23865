import numpy as np
import pytest
import torch

from tests.model.model_fixtures import FAST_TRAIN, TINY_MODEL
from rap.errors import InputError
from rap.model.network.checkpoint import FORMAT_VERSION, load_checkpoint, save_checkpoint
from rap.model.network.cnn import RobustnessCNN
from rap.model.inference.torch_engine import TorchPredictor
from rap.model.training.train import train


@pytest.fixture(scope="module")
def trained(tiny_dataset):
    return train(tiny_dataset, holdout="gamma", model_config=TINY_MODEL, config=FAST_TRAIN)


@pytest.fixture
def ckpt_path(trained, tmp_path):
    return trained.save(tmp_path / "m.pt")


def test_reload_predicts_the_same_and_carries_metadata(trained, ckpt_path, tiny_dataset):
    images = np.random.default_rng(0).integers(0, 256, (5, 2, 64, 64), dtype=np.uint8)
    with torch.no_grad():
        before = torch.softmax(trained.model.eval()(torch.from_numpy(images)), 1)[:, 1].numpy()
    p = TorchPredictor.load(ckpt_path)
    np.testing.assert_allclose(p.prob_high(images), before, rtol=0, atol=1e-6)
    assert p.threshold == 0.95
    assert p.config == TINY_MODEL
    assert p.data_fingerprint == trained.data_fingerprint and len(p.data_fingerprint) == 64
    assert [a["name"] for a in p.assemblies] == ["alpha", "beta"]
    assert p.metrics["holdout"]["assembly"] == "gamma"
    assert p.training["config"]["seed"] == 0
    assert p.image_stats["rows"] == 96


def _error(path) -> str:
    with pytest.raises(InputError) as exc:
        load_checkpoint(path)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_truncated_checkpoint(ckpt_path):
    data = ckpt_path.read_bytes()
    ckpt_path.write_bytes(data[: len(data) // 2])
    assert "not a readable checkpoint" in _error(ckpt_path)


def test_corrupted_checkpoint(ckpt_path):
    ckpt_path.write_bytes(b"this is not a checkpoint at all" * 10)
    assert "not a readable checkpoint" in _error(ckpt_path)


def test_missing_checkpoint(tmp_path):
    assert "no such checkpoint" in _error(tmp_path / "nope.pt")


def test_other_format_version(ckpt_path):
    blob = torch.load(ckpt_path, weights_only=True)
    blob["format_version"] = FORMAT_VERSION + 1
    torch.save(blob, ckpt_path)
    assert f"format version {FORMAT_VERSION + 1}" in _error(ckpt_path)


def test_not_a_rap_checkpoint(tmp_path):
    torch.save({"state_dict": {}}, tmp_path / "x.pt")
    assert "not a rap-farm robustness-CNN checkpoint" in _error(tmp_path / "x.pt")


def test_weights_that_do_not_fit_the_config(ckpt_path):
    blob = torch.load(ckpt_path, weights_only=True)
    blob["config"]["hidden"] = [64, 16, 8]
    torch.save(blob, ckpt_path)
    assert "inconsistent checkpoint" in _error(ckpt_path)


class _Payload:
    """Unpickling this would create a file: loading must refuse it without running it."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_pickled_object_is_refused_and_not_run(ckpt_path, tmp_path):
    marker = tmp_path / "pwned"
    blob = torch.load(ckpt_path, weights_only=True)
    blob["metrics"] = {"evil": _Payload(marker)}
    with open(ckpt_path, "wb") as fh:
        torch.save(blob, fh)
    assert "refused" in _error(ckpt_path)
    assert not marker.exists()


def test_only_plain_metadata_can_be_saved(tmp_path):
    model = RobustnessCNN(TINY_MODEL)
    with pytest.raises(TypeError):
        save_checkpoint(tmp_path / "m.pt", model, threshold=0.95, data_fingerprint="x",
                        assemblies=[], image_stats={}, metrics={"bad": object()}, training={})
    assert not (tmp_path / "m.pt").exists()
    path = save_checkpoint(tmp_path / "m.pt", model, threshold=np.float64(0.9),
                           data_fingerprint="x", assemblies=[("a", 1)], image_stats={},
                           metrics={"n": np.int64(3)}, training={})
    c = load_checkpoint(path)
    assert c.threshold == 0.9 and c.metrics == {"n": 3} and c.assemblies == [["a", 1]]
