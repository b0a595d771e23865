"""Cross-validation folds as parallel Ray tasks on a small local cluster."""

from dataclasses import replace

import pytest

from tests.farm.conftest import ray_local  # noqa: F401  (a fixture, used by name)
from tests.model.model_fixtures import FAST_TRAIN, TINY_MODEL
from rap.model.evaluation.cross_validation import cross_validate, fold_specs, sequential_folds

ray = pytest.importorskip("ray")
pytestmark = pytest.mark.ray


@pytest.fixture(scope="module")
def cluster(ray_local):
    """The small local Ray (2 CPUs) of tests/farm/conftest.py, shared with the farm's tests."""
    return ray_local


def test_two_folds_in_parallel_match_in_process(cluster, tiny_dataset, tmp_path):
    from rap.farm.folds import ray_folds

    config = replace(FAST_TRAIN, epochs=1)
    specs = fold_specs(tiny_dataset, TINY_MODEL, config, ["alpha", "beta"],
                       models_dir=tmp_path / "models")
    folds = cross_validate(specs, ray_folds)
    assert [f["assembly"] for f in folds] == ["alpha", "beta"]
    assert ray.is_initialized()  # an existing runtime is used and left running
    assert (tmp_path / "models" / "holdout-alpha.pt").exists()
    local = cross_validate(fold_specs(tiny_dataset, TINY_MODEL, config, ["alpha", "beta"]),
                           sequential_folds)
    for f, g in zip(folds, local):  # one torch thread either way: the same models
        assert f["metrics"]["accuracy"] == g["metrics"]["accuracy"]
        assert f["metrics"]["ece"] == pytest.approx(g["metrics"]["ece"], abs=1e-9)
