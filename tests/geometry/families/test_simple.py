"""Generators and ``rap-farm generate``."""

from __future__ import annotations

import numpy as np
import pytest

from rap.io import load_assembly
from rap.geometry.families.simple import grid, random_tiling
from rap.geometry.validation import validate_assembly


@pytest.mark.parametrize("k", [1, 2, 5])
def test_grid(k):
    g = grid(k)
    assert len(g) == k * k
    validate_assembly(g)


@pytest.mark.parametrize("n", [1, 7, 10, 24, 60])
def test_random_tiling_is_valid(n):
    for seed in range(3):
        t = random_tiling(n, np.random.default_rng(seed))
        assert len(t) == n
        validate_assembly(t)


def test_random_tiling_is_seeded():
    a = random_tiling(12, np.random.default_rng(5))
    b = random_tiling(12, np.random.default_rng(5))
    assert a.parts == b.parts


def test_cli(tmp_path, run_cli):
    code, out, _ = run_cli("generate", "grid", "--k", "3", "-o", tmp_path / "g.json")
    assert code == 0 and "9 parts" in out
    assert len(load_assembly(tmp_path / "g.json")) == 9
    code, _, _ = run_cli("generate", "tiling", "--parts", "20", "--seed", "3", "-o", tmp_path / "t.json")
    assert code == 0
    t = load_assembly(tmp_path / "t.json")
    assert t.parts == random_tiling(20, np.random.default_rng(3)).parts
