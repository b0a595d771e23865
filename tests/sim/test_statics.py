"""Static equilibrium under gravity (rap.sim.statics): known answers on small cells, the arch's
facts, and agreement with the independent settling simulation (rap.sim.settling)."""

from __future__ import annotations

import gzip
import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog

from rap.geometry.contacts import touching
from rap.sim.settling import settle
from rap.sim.statics import (DEFAULT_MARGIN, Support, _geometry, _loads, _masks, _system,
                              check_static)
from tests.sim.cells import (AFRAME, AGREEMENT, ARCH, CANTILEVER, CENTRING, DOWN, OVERHANG, SLOPE,
                             STACK, WALL, WEDGED, wall_bricks)


def test_base_alone_is_stable():
    assert check_static(STACK, ["plate"], "plate", DOWN) == Support(True)


def test_stack_builds_bottom_up_only():
    blocks = ["block1", "block2", "block3"]
    for order in itertools.permutations(blocks):
        ok = all(check_static(STACK, ["plate", *order[:k]], "plate", DOWN).stable
                 for k in range(1, 4))
        assert ok == (list(order) == blocks), order
    got = check_static(STACK, ["plate", "block1", "block3"], "plate", DOWN)
    assert not got.stable and "'block3'" in got.reason and "touches no other part" in got.reason


def test_cut_off_parts_are_named():
    got = check_static(STACK, ["plate", "block2", "block3"], "plate", DOWN)
    assert not got.stable
    assert "'block2', 'block3'" in got.reason and "nothing connected to the base" in got.reason


@pytest.mark.parametrize("friction,stable", [(0.2, False), (0.45, False), (0.55, True),
                                             (1.0, True)])
def test_block_on_slope_slides_below_the_friction_angle(friction, stable):
    # the slope's tangent is 0.5
    got = check_static(SLOPE, SLOPE.ids, "wedge", DOWN, friction=friction)
    assert got.stable == stable
    if not stable:
        assert "'block'" in got.reason and "slide" in got.reason


def test_cantilever_tips_once_its_centroid_overhangs():
    assert check_static(CANTILEVER, ["plate", "short"], "plate", DOWN).stable
    got = check_static(CANTILEVER, ["plate", "long"], "plate", DOWN, friction=10.0)
    assert not got.stable and "'long'" in got.reason
    got = check_static(OVERHANG, OVERHANG.ids, "plate", DOWN)
    assert not got.stable and "'high'" in got.reason and "'low'" not in got.reason


def test_parts_that_fail_together_are_named_by_the_program():
    got = check_static(AFRAME, AFRAME.ids, "ground", DOWN, friction=0.2)
    assert not got.stable
    assert got.reason.startswith("parts 'left', 'right' have no equilibrium")
    assert check_static(AFRAME, AFRAME.ids, "ground", DOWN, friction=0.6).stable


def test_arch_stands_only_with_its_keystone():
    assert check_static(ARCH, ARCH.ids, "ground", DOWN).stable
    for voussoir in ("left", "right"):
        got = check_static(ARCH, ["ground", voussoir], "ground", DOWN)
        assert not got.stable and repr(voussoir) in got.reason
    assert not check_static(ARCH, ["ground", "left", "right"], "ground", DOWN).stable
    # no one-part-at-a-time order keeps every intermediate stable
    for order in itertools.permutations(["left", "right", "keystone"]):
        assert not all(check_static(ARCH, ["ground", *order[:k]], "ground", DOWN).stable
                       for k in range(1, 4))


def test_arch_on_its_centring_builds_bottom_up():
    for first, second in (("left", "right"), ("right", "left")):
        for k in range(4):
            ids = ["centring", first, second, "keystone"][:k + 1]
            assert check_static(CENTRING, ids, "centring", DOWN).stable, ids
            assert settle(CENTRING, ids, "centring", DOWN).stable, ids


def test_wall_builds_course_by_course():
    bricks = wall_bricks()
    for k in range(len(bricks) + 1):
        assert check_static(WALL, ["plate", *bricks[:k]], "plate", DOWN).stable, bricks[:k]
    got = check_static(WALL, ["plate", "c1_b2"], "plate", DOWN)
    assert not got.stable and "'c1_b2'" in got.reason


def test_memoised_and_arguments_checked():
    first = check_static(WALL, WALL.ids, "plate", DOWN)
    assert check_static(WALL, list(reversed(WALL.ids)), "plate", DOWN) is first
    assert check_static(WALL, WALL.ids, "plate", (0, -9.81)).stable  # magnitude is irrelevant
    with pytest.raises(ValueError, match="base"):
        check_static(WALL, ["c0_b0"], "plate", DOWN)
    with pytest.raises(ValueError, match="gravity"):
        check_static(WALL, WALL.ids, "plate", (0, 0))
    with pytest.raises(ValueError, match="friction"):
        check_static(WALL, WALL.ids, "plate", DOWN, friction=-1)
    with pytest.raises(KeyError):
        check_static(WALL, ["plate", "nope"], "plate", DOWN)


@pytest.mark.parametrize("case", AGREEMENT, ids=[c[0] for c in AGREEMENT])
def test_agrees_with_settling(case):
    _, asm, ids, base, gravity, friction, stable = case
    assert check_static(asm, ids, base, gravity, friction).stable == stable
    got = settle(asm, ids, base, gravity, friction=friction)
    assert got.stable == stable, got


def test_the_program_alone_accepts_pre_stress_that_the_mechanisms_reject():
    for asm, ids, base, mu in ((WEDGED, WEDGED.ids, "base", 10.0),
                               (WALL, ["plate", "c0_b0", "c1_b0", "c1_b1"], "plate", 0.5)):
        geo = _geometry(asm, DEFAULT_MARGIN)
        present, movers, _ = _masks(geo, ids, base)
        a_eq, b_eq, _ = _system(geo, _loads(asm, DOWN, mu, DEFAULT_MARGIN), present, movers, DOWN)
        assert linprog(np.zeros(a_eq.shape[1]), A_eq=a_eq, b_eq=b_eq, bounds=(0, None),
                       method="highs").status == 0  # feasible: an equilibrium with pre-stress
        assert not check_static(asm, ids, base, DOWN, mu).stable
        assert not settle(asm, ids, base, DOWN, friction=mu).stable


def _grown_subsets(count: int, seed: int) -> list[list[str]]:
    """Random subsets of the wall grown from the plate, each brick touching one already in."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        ids, size = ["plate"], int(rng.integers(2, 23))
        while len(ids) < size:
            grow = sorted({q for p in ids for q in touching(WALL, p)} - set(ids))
            ids.append(grow[int(rng.integers(len(grow)))])
        out.append(ids)
    return out


def test_stable_wall_subsets_settle():
    """Soundness on random wall subsets: every one the check calls stable stays put in the
    simulation (the check is conservative on knife-edge states, which the simulation holds)."""
    verdicts = []
    for ids in _grown_subsets(16, seed=3):
        stable = check_static(WALL, ids, "plate", DOWN).stable
        verdicts.append(stable)
        if stable:
            assert settle(WALL, ids, "plate", DOWN).stable, ids
    assert any(verdicts) and not all(verdicts)


RECORDED = Path(__file__).resolve().parents[1] / "data" / "statics" / "brick-wall-22-reachable.tsv.gz"


@pytest.mark.slow
def test_the_planners_wall_subsets_get_the_recorded_answers():
    """The 10,362 subsets that reachable() checks on the wall (--base plate --gravity 0,-1) get
    exactly the verdicts and reasons recorded before the check was rewritten over precomputed
    tables and HiGHS called directly (about 4 s)."""
    lines = [x for x in gzip.decompress(RECORDED.read_bytes()).decode().splitlines()
             if not x.startswith("#")]
    assert len(lines) == 10362
    for line in lines:
        mask, stable, reason = line.split("\t")
        ids = [p for i, p in enumerate(WALL.ids) if int(mask, 16) >> i & 1]
        assert check_static(WALL, ids, "plate", DOWN) == Support(stable == "1", reason), ids
