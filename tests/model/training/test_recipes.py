"""rap.model.training.recipes: the named recipes and their overrides."""

from __future__ import annotations

import pytest

from rap.errors import InputError, ParameterError
from rap.model.training.recipes import RECIPES, recipe


def test_overrides_apply_and_unknown_names_are_refused():
    model, train = recipe("paper", epochs=3, norm="batch", lr=None)
    assert (train.epochs, model.norm) == (3, "batch")
    assert train.lr == RECIPES["paper"][1].lr  # None: not overridden
    with pytest.raises(ParameterError) as err:  # the parameter; the CLI says --recipe
        recipe("fast")
    assert (err.value.parameter, str(err.value)) == ("recipe", "recipe 'fast': one of paper, robust")
    with pytest.raises(InputError, match="unknown recipe field 'colour'"):
        recipe("paper", colour="red")
