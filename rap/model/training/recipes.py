"""Named training recipes: a network configuration and a training configuration that go together.

* ``paper``: the paper's CNN (four 4x4 convolutions, three fully connected layers) with its loss,
  class-weighted cross-entropy over (not high, high), Adam at 1e-3, 8 epochs.
* ``robust``: the recipe this project ships (see docs/RESULTS.md for the ablation that chose
  each part): batch normalisation, the binomial head trained on the success counts, mirror
  augmentation, a cosine learning-rate schedule and a calibration temperature fitted on held-out
  assemblies.

``recipe(name, **overrides)`` returns both configurations with fields overridden by name (each
override goes to whichever of the two dataclasses has that field).
"""

from __future__ import annotations

from dataclasses import fields, replace

from rap.errors import InputError, ParameterError
from rap.model.network.cnn import ModelConfig
from rap.model.training.train import TrainConfig

__all__ = ["RECIPES", "recipe", "DEFAULT_RECIPE"]

RECIPES: dict[str, tuple[ModelConfig, TrainConfig]] = {
    "paper": (ModelConfig(), TrainConfig(epochs=8)),
    "robust": (ModelConfig(norm="batch", head="binomial"),
               TrainConfig(epochs=8, augment="hflip", schedule="cosine", calibrate=True)),
}
DEFAULT_RECIPE = "robust"


def recipe(name: str, **overrides) -> tuple[ModelConfig, TrainConfig]:
    """The recipe's (ModelConfig, TrainConfig) with ``overrides`` applied (None values skipped);
    ``ParameterError`` (parameter ``recipe``) for a name not in ``RECIPES``."""
    if name not in RECIPES:
        raise ParameterError("recipe", name, f"one of {', '.join(RECIPES)}")
    model, train = RECIPES[name]
    mf = {f.name for f in fields(ModelConfig)}
    tf = {f.name for f in fields(TrainConfig)}
    m_over, t_over = {}, {}
    for k, v in overrides.items():
        if v is None:
            continue
        if k in mf:
            m_over[k] = v
        elif k in tf:
            t_over[k] = v
        else:
            raise InputError(f"unknown recipe field {k!r}")
    if "view" in m_over and "in_channels" not in m_over:
        from rap.render.images import view_channels

        try:
            m_over["in_channels"] = view_channels(m_over["view"])
        except ValueError as exc:
            raise InputError(str(exc)) from None
    try:
        return replace(model, **m_over), replace(train, **t_over)
    except ValueError as exc:
        raise InputError(str(exc)) from None
