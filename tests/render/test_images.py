"""Start/goal image pairs: orientation normalisation, invariance, determinism, files."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rap.operation import Operation, unit
from rap.render.images import (FIXED, MOVING, render_many, render_masks, render_pair,
                               render_start_goal_png)


def _fixtures():
    name = "rap_tests_sim_fixtures"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, Path(__file__).resolve().parents[1] / "sim" / "fixtures.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        sys.modules[name] = mod
    return sys.modules[name]


FX = _fixtures()
CASES = FX.CASES


def _centroid(mask):
    rows, cols = np.indices(mask.shape)
    w = mask.sum()
    return (rows * mask).sum() / w, (cols * mask).sum() / w


@pytest.mark.parametrize("name", sorted(CASES))
def test_pair_shape_values_and_determinism(name):
    a, o = CASES[name]
    img = render_pair(a, o)
    assert img.shape == (2, 64, 64) and img.dtype == np.uint8
    assert np.array_equal(img, render_pair(a, o))
    for ch in img:
        values = set(np.unique(ch).tolist())
        assert {0, FIXED, MOVING} <= values  # background, fixed, moving (plus anti-aliased edges)
    assert len(set(np.unique(img[1]).tolist())) > 3  # anti-aliased


@pytest.mark.parametrize("name", sorted(CASES))
def test_motion_points_down(name):
    a, o = CASES[name]
    m = render_masks(a, o)
    r0, c0 = _centroid(m[0, 1])
    r1, c1 = _centroid(m[1, 1])
    assert r0 < r1 - 2  # the moving part starts above its goal (rows grow downward)
    assert abs(c0 - c1) < 0.5  # and travels straight down
    assert np.allclose(m[0, 0], m[1, 0])  # the fixed part does not move


@pytest.mark.parametrize("dx,dy", [(0, -1), (1, 0), (-1, 0), (0, 1), (3, -4), (-2, 7)])
def test_any_direction_is_rotated_to_downward(dx, dy):
    a = FX.ASSEMBLIES["beside"]
    o = Operation(frozenset({"box"}), frozenset({"block"}), unit(dx, dy))
    m = render_masks(a, o)
    r0, c0 = _centroid(m[0, 1])
    r1, c1 = _centroid(m[1, 1])
    assert r0 < r1 - 2 and abs(c0 - c1) < 0.5


def _invariants(goal_masks):
    """Rotation- and scale-invariant statistics of a goal image: area ratio moving/fixed and the
    normalised polar moment of each subassembly about the union's centroid."""
    fixed, moving = goal_masks
    union = fixed + moving
    rc, cc = _centroid(union)
    rows, cols = np.indices(union.shape)
    r2 = (rows - rc) ** 2 + (cols - cc) ** 2
    out = [moving.sum() / fixed.sum()]
    for m in (fixed, moving):
        out.append((r2 * m).sum() / union.sum() ** 2)
    return np.array(out)


def test_goal_image_is_the_same_up_to_rotation_and_scale():
    a, o1 = CASES["corner"]  # the same split, from two directions
    _, o2 = CASES["corner_shallow"]
    s1 = _invariants(render_masks(a, o1, size=128)[1])
    s2 = _invariants(render_masks(a, o2, size=128)[1])
    assert np.allclose(s1, s2, rtol=0.03), (s1, s2)
    # a different split has clearly different statistics (the test can fail)
    b, o3 = CASES["beside"]
    s3 = _invariants(render_masks(b, o3, size=128)[1])
    assert not np.allclose(s1, s3, rtol=0.03)


def test_render_many_and_png(tmp_path):
    a, o = CASES["funnel_peg"]
    many = render_many(a, [o, o])
    assert many.shape == (2, 2, 64, 64) and np.array_equal(many[0], render_pair(a, o))
    path = render_start_goal_png(a, o, tmp_path / "pair.png", size=96)
    with Image.open(path) as im:
        assert im.size[1] == 96 and im.size[0] > 2 * 96


# sha256 (first 32 hex digits) of render_pair then render_crop bytes for every candidate of the
# whole assembly, recorded with the renderer the shipped model's corpus was made with, under this
# Pillow (its rasteriser decides the anti-aliased edges; another version may draw them otherwise).
GOLDEN_PILLOW = "13.0.0"
GOLDEN = {"triangles": (3, "30fef98e2b90ef5c1da735ade38f6aee"),
          "hexagon": (10, "0588371e86bfc224d7f76fcc16e0032b")}


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_images_are_the_ones_the_model_was_trained_on(name):
    """A faster renderer must draw the same bytes: the network learned these pixels."""
    import hashlib

    import PIL

    from rap.io import load_assembly
    from rap.plan.problem import PlanningProblem
    from rap.render.images import render_crop
    from rap.sim.params import DEFAULT_PARAMS

    if PIL.__version__ != GOLDEN_PILLOW:
        pytest.skip(f"digests recorded under Pillow {GOLDEN_PILLOW}, not {PIL.__version__}")
    asm = load_assembly(Path(__file__).resolve().parents[2] / "assemblies" / f"{name}.json")
    problem = PlanningProblem(asm, DEFAULT_PARAMS, 0, "online")
    ops = problem.candidates(problem.whole)
    h = hashlib.sha256()
    for op in ops:
        h.update(render_pair(asm, op).tobytes())
        h.update(render_crop(asm, op).tobytes())
    assert (len(ops), h.hexdigest()[:32]) == GOLDEN[name]
