"""ScoreCorrection: the identity before any simulation, lower (higher) where the simulations came
out lower (higher) than predicted, shrunk by its prior, per bin of the model's score."""

from __future__ import annotations

import math

import pytest

from research.variants.score_correction import EDGES, ScoreCorrection

PS = [0.0, 0.03, 0.5, 0.81, 0.9, 0.949, 0.97, 0.995, 1.0]


def logit(x, trials=100):
    x = (trials * x + 0.5) / (trials + 1)
    return math.log(x / (1 - x))


@pytest.mark.parametrize("edges", [EDGES, ()])
def test_without_simulations_it_is_the_identity(edges):
    c = ScoreCorrection(5.0, edges)
    assert [c(p) for p in PS] == PS and c.pooled == 0.0 and c.shift(0.9) == 0.0
    for p in (0.7, 0.92, 0.99):  # a simulation that matches its prediction adds nothing
        c.add(p, p)
    assert [c(p) for p in PS] == pytest.approx(PS, abs=1e-12)


@pytest.mark.parametrize("edges", [EDGES, ()])
def test_lower_simulations_lower_every_unsimulated_prediction(edges):
    c = ScoreCorrection(2.0, edges)
    for p, s in ((0.9, 0.8), (0.93, 0.85), (0.85, 0.7), (0.96, 0.9)):
        c.add(p, s)
    assert c.pooled < 0.0
    for p in PS[1:-1]:  # every bin, those without a simulation too (by the pooled shift)
        assert c(p) < p
    assert c(0.0) == 0.0 and c(1.0) < 1.0  # [0, 1], and 1 is not a certainty either
    inside = [0.905, 0.91, 0.93, 0.949]  # monotone within a bin
    assert [c(p) for p in inside] == sorted(c(p) for p in inside)
    up = ScoreCorrection(2.0, edges)
    for p, s in ((0.9, 0.97), (0.8, 0.9)):
        up.add(p, s)
    assert all(up(p) > p for p in PS[:-1])


def test_prior_shrinks_and_zero_prior_is_the_mean_residual():
    pairs = [(0.9, 0.8), (0.92, 0.9), (0.91, 0.7)]
    moved = []
    for prior in (0.0, 1.0, 5.0, 50.0):
        c = ScoreCorrection(prior, ())
        for p, s in pairs:
            c.add(p, s)
        moved.append(0.9 - c(0.9))
    assert moved == sorted(moved, reverse=True) and moved[-1] > 0.0
    c = ScoreCorrection(0.0, ())
    for p, s in pairs:
        c.add(p, s)
    mean = sum(logit(s) - logit(p) for p, s in pairs) / len(pairs)
    assert c.pooled == pytest.approx(mean, rel=1e-12)
    assert logit(c(0.93)) == pytest.approx(logit(0.93) + mean, rel=1e-9)


def test_a_bin_follows_its_own_simulations_and_the_others_lean_on_the_pool():
    c = ScoreCorrection(1.0)
    for _ in range(10):  # mid-range operations much worse than predicted
        c.add(0.85, 0.6)
    for _ in range(10):  # high ones as predicted
        c.add(0.97, 0.97)
    assert c(0.85) < 0.7 and 0.96 < c(0.97) < 0.97  # each bin near its own residuals
    assert c(0.86) < c(0.93) < 0.93  # an empty bin: the pooled shift


def test_invalid_arguments():
    with pytest.raises(ValueError):
        ScoreCorrection(-1.0)
    for edges in ((0.9, 0.8), (0.0, 0.5), (0.5, 1.0), (0.5, 0.5)):
        with pytest.raises(ValueError):
            ScoreCorrection(1.0, edges)
