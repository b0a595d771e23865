"""Split-conformal score bounds: coverage on fresh draws, the conformal rank, special bounds, files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rap.model.calibration import FORMAT, MeanBounds, ScoreBounds, fit, load, min_count, save
from rap.stats import bonferroni


def draw(rng, n):
    """A synthetic calibration set: p uniform, simulated = p + noise whose spread depends on p
    (wide in the middle, narrow near 0 and 1), on the simulator's grid of 1/100, in [0, 1]."""
    p = rng.uniform(0.0, 1.0, n)
    noise = rng.normal(0.0, 0.05 + 0.25 * p * (1 - p), n)
    s = np.clip(np.round((p + noise) * 100) / 100, 0.0, 1.0)
    return p, s


@pytest.mark.parametrize("level", [0.8, 0.9, 0.95])
def test_coverage_on_fresh_draws(level):
    rng = np.random.default_rng(7)
    bounds = fit(*draw(rng, 3000), bins=6)
    p, s = draw(rng, 30000)
    up = bounds.upper(p, level)
    n_bin = min(bounds.counts)
    tol = 3 * math.sqrt(level * (1 - level) / n_bin) + 3 * math.sqrt(level * (1 - level) / p.size)
    assert np.mean(s <= up) >= level - tol
    for b in range(len(bounds.counts)):  # Mondrian: the guarantee holds in every bin
        inside = bounds.bin_of(p) == b
        assert np.mean(s[inside] <= up[inside]) >= level - 3 * tol
    # and the bound is not trivial: narrower than 1 on most operations
    assert np.mean(up < 1.0) > 0.5


def test_mean_bounds_cover_the_mean_of_two_predictions():
    """Two scorers of the same operations, one biased low and one noisy; a score that is the
    mean of their predictions is covered by MeanBounds at the level, and the bound is at least
    the lower scorer's own bound at its own prediction (half the miss rate)."""
    rng = np.random.default_rng(11)

    def two(n):
        s = np.clip(np.round(rng.uniform(0, 1, n) * 100) / 100, 0, 1)
        low = np.clip(s - 0.1 + rng.normal(0, 0.05, n), 0, 1)
        noisy = np.clip(s + rng.normal(0, 0.15, n), 0, 1)
        return s, low, noisy

    s, a, b = two(4000)
    both = MeanBounds(fit(a, s), fit(b, s))
    s, a, b = two(40000)
    level = 0.9
    up = both.upper((a + b) / 2, level)
    assert np.mean(s <= up) >= level - 0.01
    half = (1 + level) / 2
    own = np.where(a <= b, both.first.upper(a, half), both.second.upper(b, half))
    assert np.all(up >= own - 1e-12)
    assert both.calibrated and not both.perfect
    named = MeanBounds(ScoreBounds(provenance={"model": "m1", "date": "d"}), ScoreBounds.trivial())
    assert named.provenance["model"].startswith("the mean of two fits (m1, d; ")
    assert not named.calibrated  # the trivial fit bounds by 1: so does the pair


def test_rising_is_the_least_monotone_bound_above_upper():
    """A bin of wide residuals under one of narrow ones makes ``upper`` fall at the edge;
    ``rising`` does not fall, is at least ``upper`` at every lower score, and equals it where
    ``upper`` already rises."""
    p = np.concatenate([np.full(300, 0.3), np.full(300, 0.8)])
    s = np.concatenate([np.linspace(0.0, 0.9, 300), np.full(300, 0.81)])
    b = fit(p, s, bins=2)
    q = np.linspace(0, 1, 201)
    up, rise = b.upper(q, 0.9), b.rising(q, 0.9)
    assert np.any(np.diff(up) < 0)  # the fixture does fall
    assert np.all(np.diff(rise) >= 0)
    assert np.all(rise >= np.maximum.accumulate(up) - 1e-12)
    np.testing.assert_array_equal(rise[q < b.edges[0]], up[q < b.edges[0]])


def test_conformal_rank_and_small_bins():
    # one bin with residuals 0.01 .. 0.19 (19 of them): rank ceil(20 x 0.95) = 19 -> 0.19
    b = ScoreBounds((), (tuple(i / 100 for i in range(1, 20)),))
    assert b.upper(np.array([0.5]), 0.95)[0] == pytest.approx(0.69)
    assert b.upper(np.array([0.5]), 0.9)[0] == pytest.approx(0.5 + 0.18)  # ceil(18.0) = 18
    assert b.upper(np.array([0.5]), 0.96)[0] == 1.0  # rank 20 > 19 residuals: trivial bound
    assert b.upper(np.array([0.95]), 0.95)[0] == 1.0  # clipped to 1
    assert min_count(0.95) == 19 and min_count(0.9) == 9 and min_count(0.995) == 199
    for level in (0.5, 0.8, 0.95, 0.99):
        n = min_count(level)
        assert math.ceil(round((n + 1) * level, 9)) <= n < n + 1
        assert math.ceil(round(n * level, 9)) > n - 1


def test_bins_follow_quantiles_and_lookup():
    rng = np.random.default_rng(1)
    p, s = draw(rng, 1200)
    b = fit(p, s, bins=6)
    assert len(b.edges) == 5 and sum(b.counts) == 1200
    assert max(b.counts) - min(b.counts) <= 2
    assert b.provenance["operations"] == 1200 and b.provenance["bins"] == 6
    # residuals per bin are exactly the (rounded-up) residuals of the scores in that bin
    idx = b.bin_of(p)
    for i, r in enumerate(b.residuals):
        want = np.sort(np.ceil((s[idx == i] - p[idx == i]) * 1e6) / 1e6)
        assert np.array_equal(np.array(r), want)


def test_special_bounds():
    p = np.array([0.0, 0.3, 0.99])
    assert np.array_equal(ScoreBounds.zero_width().upper(p, 0.999), p)
    assert np.array_equal(ScoreBounds.trivial().upper(p, 0.5), np.ones(3))
    assert not ScoreBounds.trivial().calibrated and ScoreBounds.zero_width().calibrated
    # a single-valued p (every quantile equal): one bin, still a valid fit
    b = fit(np.full(50, 0.5), np.full(50, 0.6))
    assert b.counts == (50,) and b.upper(np.array([0.2]), 0.9)[0] == pytest.approx(0.3)


def test_bonferroni():
    assert bonferroni(0.95, 10) == pytest.approx(0.995)
    assert bonferroni(0.95, 0) == pytest.approx(0.95)


@pytest.mark.parametrize("bad", [
    dict(predicted=[0.5, 0.2], simulated=[0.5]),
    dict(predicted=[1.5], simulated=[0.5]),
    dict(predicted=[np.nan], simulated=[0.5]),
])
def test_fit_rejects_bad_input(bad):
    with pytest.raises(ValueError):
        fit(bad["predicted"], bad["simulated"])


def test_bad_levels():
    assert ScoreBounds.trivial().upper([0.5], 1.0)[0] == 1.0  # level 1: the trivial bound
    assert ScoreBounds.zero_width().upper([0.5], 1.0)[0] == 0.5
    for level in (0.0, -1, 2):
        with pytest.raises(ValueError, match="level"):
            ScoreBounds.trivial().upper([0.5], level)


def test_json_round_trip_and_files(tmp_path):
    rng = np.random.default_rng(3)
    b = fit(*draw(rng, 400), bins=5, provenance={"model": "m.pt", "set": "synthetic"})
    doc = json.loads(json.dumps(b.to_json()))
    back = ScoreBounds.from_json(doc)
    assert back == b and back.provenance == b.provenance
    p = rng.uniform(0, 1, 100)
    assert np.array_equal(back.upper(p, 0.9), b.upper(p, 0.9))
    path = save(b, tmp_path / "bounds.json")
    assert load(path) == b
    with pytest.raises(ValueError, match=FORMAT):
        ScoreBounds.from_json({"format": "other"})
    with pytest.raises(FileNotFoundError):
        load(tmp_path / "absent.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(ValueError, match="not JSON"):
        load(tmp_path / "bad.json")


def test_default_load_without_file(monkeypatch, tmp_path):
    import rap.model.calibration as sb

    monkeypatch.setattr(sb, "DEFAULT_PATH", tmp_path / "score_bounds.json")
    b = sb.load()
    assert not b.calibrated and "bounded by 1" in b.provenance["note"]
