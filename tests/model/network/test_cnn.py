import pytest
import torch

from rap.model.network.cnn import ModelConfig, RobustnessCNN


def test_default_network_shape_and_size():
    model = RobustnessCNN(ModelConfig())
    convs = [m for m in model.modules() if isinstance(m, torch.nn.Conv2d)]
    linears = [m for m in model.modules() if isinstance(m, torch.nn.Linear)]
    assert len(convs) == 4 and all(c.kernel_size == (4, 4) for c in convs)
    assert len(linears) == 4 and linears[-1].out_features == 2  # three hidden + output
    assert model.num_parameters() == 410_866
    assert model(torch.zeros(3, 2, 64, 64)).shape == (3, 2)


def test_uint8_input_is_scaled_like_float():
    torch.manual_seed(0)
    model = RobustnessCNN(ModelConfig(channels=(4, 4, 4, 4), hidden=(8, 8, 8))).eval()
    x = torch.randint(0, 256, (2, 2, 64, 64), dtype=torch.uint8)
    assert torch.allclose(model(x), model(x.float() / 255))


def test_config_round_trips_through_a_plain_dict():
    cfg = ModelConfig(channels=(8, 8, 16, 16), hidden=(64, 32, 16), dropout=0.2)
    d = cfg.to_dict()
    assert d["channels"] == [8, 8, 16, 16]
    assert ModelConfig.from_dict(d) == cfg
    with pytest.raises(ValueError):
        ModelConfig.from_dict({**d, "bogus": 1})


@pytest.mark.parametrize("norm, training", [("none", True), ("none", False), ("batch", False),
                                            ("batch", True)])
def test_the_forward_pass_is_the_plain_layer_stack(norm, training):
    """The convolutions skip the rows the pooling drops: the logits are the full stack's."""
    torch.manual_seed(0)
    net = RobustnessCNN(ModelConfig(norm=norm, dropout=0.0))
    net.train(training)
    x = torch.rand(5, 2, 64, 64)
    full = net.head(net.features(x.contiguous(memory_format=torch.channels_last)))
    torch.testing.assert_close(net(x), full, rtol=1e-5, atol=1e-5)
