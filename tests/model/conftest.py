"""Fixtures of the model tests; the data they build is defined in ``model_fixtures``."""

import pytest
import torch

from model_fixtures import write_synthetic


@pytest.fixture(autouse=True)
def _one_thread():
    old = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(old)


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory):
    """Three assemblies x 48 rows, two shards each."""
    return write_synthetic(tmp_path_factory.mktemp("tiny"))


@pytest.fixture(scope="session")
def learnable_dataset(tmp_path_factory):
    """Three assemblies x 160 rows: enough for the rule to be learnt across assemblies."""
    return write_synthetic(tmp_path_factory.mktemp("learnable"), n=160, seed=1)


@pytest.fixture(scope="session")
def family_dataset(tmp_path_factory):
    """Four assemblies in two families (plus a reference one): for family folds."""
    return write_synthetic(tmp_path_factory.mktemp("families"),
                           names=("alpha", "beta", "gamma", "delta", "ref"), n=96, seed=2,
                           families={"alpha": "walls", "beta": "walls", "gamma": "pegs",
                                     "delta": "pegs", "ref": "reference"})
