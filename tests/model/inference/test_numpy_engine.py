"""The torch-free engine of the CNN (rap.model.inference.numpy_engine) against torch, and OperationPredictor's calls
(rap.model.inference.operations) in both engines."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import rap
from rap.io import load_assembly
from rap.model.inference.numpy_engine import _conv_nhwc, load_numpy_predictor, read_torch_checkpoint
from rap.model.inference.operations import OperationPredictor
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

DATA = Path(rap.__file__).parent / "data"


def six(name: str):
    return load_assembly(DATA / "assemblies" / f"{name}.json")


def _inputs(name: str, predictor) -> tuple[np.ndarray, np.ndarray | None]:
    """The whole assembly's candidates as ``predictor`` takes them: images, and descriptors when
    its network has them (``OperationPredictor.descriptors``)."""
    problem = PlanningProblem(six(name), SimParams())
    ops = list(problem.candidates(problem.whole))
    cnn = OperationPredictor(predictor)
    return cnn.images(problem, ops), cnn.descriptors(problem, ops)


def test_shipped_model_runs_without_torch_and_agrees_with_torch():
    torch_predict = pytest.importorskip("rap.model.inference.torch_engine")
    path = DATA / "default_model.pt"
    fast = load_numpy_predictor(path)
    assert fast is not None, "the shipped checkpoint should run in numpy"
    slow = torch_predict.TorchPredictor.load(path)
    (ia, da), (ib, db) = _inputs("hexagon", fast), _inputs("rectilinear", fast)
    images = np.concatenate([ia, ib])
    d = None if da is None else np.concatenate([da, db])
    np.testing.assert_allclose(fast.prob_high(images, d), slow.prob_high(images, d), atol=1e-5)
    assert fast.threshold == slow.threshold
    assert fast.assemblies == slow.assemblies and fast.image_stats == slow.image_stats
    assert fast.prob_high(images[:0], None if d is None else d[:0]).shape == (0,)


def test_both_numbers_from_one_pass_equal_the_separate_calls_in_torch_and_numpy():
    torch_predict = pytest.importorskip("rap.model.inference.torch_engine")
    path = DATA / "default_model.pt"
    problem = PlanningProblem(six("hexagon"), SimParams())
    ops = list(problem.candidates(problem.whole))
    for engine in ("auto", "torch"):
        cnn = OperationPredictor.load(path, engine=engine)
        ph, e = cnn.prob_high_and_expected(problem, ops)
        np.testing.assert_array_equal(ph, cnn.prob_high(problem, ops))
        np.testing.assert_array_equal(e, cnn.expected_score(problem, ops))
        order = np.argsort(e)  # binomial head: P(high) is monotone in the expected score
        assert np.all(np.diff(ph[order]) >= 0)
    images, d = _inputs("hexagon", load_numpy_predictor(path))
    ph, e = torch_predict.TorchPredictor.load(path).prob_high_and_expected(images, d)
    assert np.shape(ph) == np.shape(e) == (len(images),)  # one pair of numbers an operation
    assert np.all((0 <= ph) & (ph <= 1)) and np.all((0 <= e) & (e <= 1))


def test_mirror_averaging_is_the_mean_of_both_passes_in_torch_and_numpy():
    torch_predict = pytest.importorskip("rap.model.inference.torch_engine")
    path = DATA / "default_model.pt"
    fast, slow = load_numpy_predictor(path), torch_predict.TorchPredictor.load(path)
    images, d = _inputs("hexagon", fast)  # descriptors are mirror-invariant: the same for both
    flipped = np.ascontiguousarray(images[..., ::-1])
    plain, mirror = fast.outputs(images, d), fast.outputs(flipped, d)
    assert not np.allclose(plain, mirror)  # the network is not mirror-symmetric by itself
    fast.mirror, slow.mirror = True, True
    np.testing.assert_allclose(fast.outputs(images, d), (plain + mirror) / 2, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(fast.outputs(images, d), fast.outputs(flipped, d), atol=1e-6)
    np.testing.assert_allclose(fast.prob_high(images, d), slow.prob_high(images, d), atol=1e-5)
    cnn = OperationPredictor.load(path, engine="auto", mirror=True)
    assert cnn.predictor.engine == "numpy" and cnn.predictor.mirror
    assert torch_predict.TorchPredictor.load(path, mirror=True).mirror


@pytest.mark.parametrize("norm,head,temperature,descriptors", [
    ("none", "class", 1.0, False), ("batch", "class", 1.7, False), ("none", "binomial", 1.0, False),
    ("batch", "binomial", 0.8, False), ("batch", "binomial", 0.8, True)])
def test_a_fresh_network_of_the_current_architecture_agrees(tmp_path, norm, head, temperature,
                                                            descriptors):
    """Catches a change of RobustnessCNN or of the heads that the numpy forward pass does not
    follow: every configuration the model layer offers, with a calibration temperature."""
    torch = pytest.importorskip("torch")
    from rap.model.network.checkpoint import save_checkpoint
    from rap.model.network.cnn import ModelConfig, RobustnessCNN
    from rap.model.inference.torch_engine import TorchPredictor

    from rap.model.data.descriptors import DESCRIPTORS

    torch.manual_seed(3)
    names = DESCRIPTORS if descriptors else ()
    model = RobustnessCNN(ModelConfig(norm=norm, head=head, descriptors=names))
    with torch.no_grad():  # larger weights than the init, and batch statistics of some training
        for p in model.parameters():
            p.mul_(1.6)
        for m in model.modules():
            if isinstance(m, (torch.nn.BatchNorm1d, torch.nn.BatchNorm2d)):
                m.running_mean.uniform_(-0.5, 0.5)
                m.running_var.uniform_(0.5, 2.0)
        if head == "binomial":  # per-trial success rates around 0.9: P(high) away from 0 and 1
            model.head[-1].bias.fill_(2.2)
    model.eval()
    path = save_checkpoint(tmp_path / "m.pt", model, threshold=0.9, data_fingerprint="x",
                           assemblies=[], image_stats={}, metrics={}, training={"trials": 40},
                           calibration={"temperature": temperature})
    fast = load_numpy_predictor(path)
    assert fast is not None
    rng = np.random.default_rng(0)
    images = (rng.random((20, 2, 64, 64)) < 0.4).astype(np.uint8) * rng.integers(
        0, 256, (20, 2, 64, 64), dtype=np.uint8)
    d = rng.normal(size=(20, len(names))).astype(np.float32) if names else None
    slow = TorchPredictor.load(path)
    assert fast.descriptors == slow.descriptors == names
    z_fast, z_torch = fast.outputs(images, d), slow.outputs(images, d)
    np.testing.assert_allclose(z_fast, z_torch, rtol=0, atol=1e-5 * np.abs(z_torch).max())
    p_fast, p_torch = fast.prob_high(images, d), slow.prob_high(images, d)
    assert p_torch.std() > 1e-3
    np.testing.assert_allclose(p_fast, p_torch, atol=1e-5)
    np.testing.assert_allclose(fast.expected_score(images, d), slow.expected_score(images, d),
                               atol=1e-5)


@pytest.mark.parametrize("size, kernel, pad", [(64, 4, 2), (33, 4, 2), (17, 3, 1), (9, 4, 0)])
def test_even_convolution_is_the_full_one_without_the_rows_pooling_drops(size, kernel, pad):
    rng = np.random.default_rng(size)
    x = rng.random((3, size, size, 5), dtype=np.float32)
    w = rng.standard_normal((7, 5, kernel, kernel)).astype(np.float32)
    full = _conv_nhwc(x, w, pad)
    even = _conv_nhwc(x, w, pad, even=True)
    ho = full.shape[1] - full.shape[1] % 2
    assert even.shape == (3, ho, ho, 7)
    np.testing.assert_allclose(even, full[:, :ho, :ho], rtol=1e-5, atol=1e-5)


def test_anything_but_the_known_architecture_is_left_to_torch(tmp_path):
    import zipfile

    assert load_numpy_predictor(tmp_path / "missing.pt") is None
    (tmp_path / "junk.pt").write_bytes(b"not a zip")
    assert load_numpy_predictor(tmp_path / "junk.pt") is None
    # a pickle that names another global is refused, not executed
    src = zipfile.ZipFile(DATA / "default_model.pt")
    with zipfile.ZipFile(tmp_path / "evil.pt", "w") as dst:
        for name in src.namelist():
            data = src.read(name)
            if name.endswith("data.pkl"):
                assert b"collections\nOrderedDict\n" in data
                data = data.replace(b"collections\nOrderedDict\n", b"os\nsystem\n")
            dst.writestr(name, data)
    with pytest.raises(pickle.UnpicklingError, match="os.system is not admitted"):
        read_torch_checkpoint(tmp_path / "evil.pt")
    assert load_numpy_predictor(tmp_path / "evil.pt") is None
