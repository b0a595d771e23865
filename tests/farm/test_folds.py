"""rap.farm.folds reaches Ray through rap.farm.runtime.connect (the folds themselves:
tests/model/test_folds_ray.py)."""

from __future__ import annotations

import pytest

ray = pytest.importorskip("ray")
pytestmark = pytest.mark.ray


def test_the_folds_connect_as_the_farm_does():
    from rap.farm import folds, runtime

    assert folds.connect is runtime.connect


def test_a_ray_the_folds_started_is_shut_down():
    from rap.farm.folds import ray_folds

    assert not ray.is_initialized()
    assert list(ray_folds([], num_cpus=1)) == []
    assert not ray.is_initialized()
