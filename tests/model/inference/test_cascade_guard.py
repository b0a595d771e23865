"""The default scorer's guard (rap.model.inference.cascade, descriptor_model.Familiarity): a
familiar assembly is scored and bounded exactly as without it; an unfamiliar one (a held-out
shape kind) is flagged, scored by the mean of the trees' and the CNN's numbers and bounded by both
fits (MeanBounds); the plan says so; its plan reaches 0.95 of the optimum."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import rap
from rap.geometry.families import generate
from rap.model.calibration import load as cnn_bounds
from rap.model.inference.cascade import CascadeScorer, GuardedBounds, guard_path, companion
from rap.model.inference.descriptor_model import Familiarity, size_free
from rap.model.inference.operations import OperationPredictor
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

SHIPPED = Path(rap.__file__).parent / "data" / "default_model.pt"
FAMILIAR = ("wall", 200)  # a fresh seed of a training family
UNFAMILIAR = ("arch", 1)  # a held-out shape kind, 6 parts


@pytest.fixture(scope="module")
def cascade():
    c = OperationPredictor.load(SHIPPED, engine="auto")
    assert isinstance(c, CascadeScorer) and c.guard is not None  # shipped with its guard
    return c


def _problem(name_seed):
    return PlanningProblem(generate(*name_seed), SimParams())


def test_the_guard_file_round_trips(tmp_path):
    fam = Familiarity.load(guard_path(companion(SHIPPED)))
    again = Familiarity.load(fam.save(tmp_path / "g.npz"))
    assert (again.limit, again.share, again.k) == (fam.limit, fam.share, fam.k)
    np.testing.assert_array_equal(again.reference, fam.reference)
    assert fam.meta["quantile"] == 0.9 and fam.share == 0.4 and len(fam.reference) == 60000
    assert again.columns == fam.columns == size_free(fam.log_columns)
    np.testing.assert_array_equal(again.high, fam.high)


@pytest.mark.parametrize("k", [5, 10])
def test_a_large_assembly_of_a_known_kind_is_familiar(cascade, k):
    """Size is not a shape kind: a 25- or 100-part grid, larger than any corpus assembly (at
    most 16 parts), is familiar (the guard leaves the part counts and the area fraction out)."""
    from rap.geometry.families.simple import grid

    v = cascade.verdict(PlanningProblem(grid(k), SimParams()))
    assert v["operations"] == 64 and v["outside"] < 0.1 and not v["unfamiliar"]


def test_the_size_free_columns_leave_out_the_counts_and_the_area_fraction():
    from rap.model.data.descriptors import DESCRIPTORS

    cols = size_free((0, 1, 7, 8, 9))
    kept = [DESCRIPTORS[c] for c in cols if c < 12]
    assert {"moving_parts", "fixed_parts", "log_area_fraction"}.isdisjoint(kept)
    assert len(kept) == 9 and cols[9:] == [12, 13, 14, 15, 16]


def test_familiar_assembly_is_scored_and_bounded_as_without_the_guard(cascade):
    problem = _problem(FAMILIAR)
    ops = list(problem.candidates(problem.whole))
    bare = CascadeScorer(cascade.cnn, cascade.model, bounds=cascade._bounds)
    got, want = cascade.prob_high_and_expected(problem, ops), bare.prob_high_and_expected(problem, ops)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert not cascade.verdict(problem)["unfamiliar"] and cascade.guard_report(problem) is None
    p = np.linspace(0, 1, 11)
    np.testing.assert_array_equal(cascade.bounds.upper(p, 0.99), bare.bounds.upper(p, 0.99))


def test_unfamiliar_assembly_is_flagged_and_takes_the_mean_of_the_trees_and_the_cnn(cascade):
    """On an unfamiliar assembly every operation is scored by the CNN too and takes the mean of
    the two models' numbers; the bounds are both fits' rising envelopes at half the miss rate
    each (MeanBounds), at least the lower model's own bound at its own number."""
    from rap.model.calibration import MeanBounds

    problem = _problem(UNFAMILIAR)
    ops = list(problem.candidates(problem.whole))
    v = cascade.verdict(problem)
    assert v["unfamiliar"] and v["outside"] > v["share"]
    before = cascade.guarded
    p, e = cascade.prob_high_and_expected(problem, ops)
    assert cascade.guarded - before == len(ops)
    cnn = cascade.cnn.prob_high_and_expected(problem, ops)
    trees = cascade.model.prob_high_and_expected(cascade.descriptors(problem, ops))
    np.testing.assert_allclose(e, (cnn[1] + trees[1]) / 2, atol=1e-6)
    np.testing.assert_allclose(p, (cnn[0] + trees[0]) / 2, atol=1e-6)
    assert np.any(cnn[1] > trees[1] + 1e-3) and np.any(trees[1] > cnn[1] + 1e-3)  # both count
    bounds = cascade.bounds
    assert isinstance(bounds, GuardedBounds) and isinstance(cascade.active_bounds(), MeanBounds)
    q = np.linspace(0, 1, 11)
    half = (1 + 0.99) / 2
    want = np.maximum(cnn_bounds().rising(q, half), cascade._bounds.rising(q, half))
    np.testing.assert_array_equal(bounds.upper(q, 0.99), want)
    lower = np.where(cnn[1] <= trees[1], cnn_bounds().upper(cnn[1], half),
                     cascade._bounds.upper(trees[1], half))  # the lower model's, at its number
    assert np.all(bounds.upper(e, 0.99) >= lower - 1e-12)
    assert bounds.calibrated and not bounds.perfect and "mean of two" in bounds.provenance["model"]
    assert "mean of the trees' and the CNN's" in cascade.guard_report(problem)["action"]


def test_batch_first_follows_the_assembly_judged_last(cascade):
    """The trees' whole-graph batch pays only where the trees answer: not on an unfamiliar
    assembly, whose every operation goes to the CNN (per operation: ask lazily)."""
    cascade.verdict(_problem(UNFAMILIAR))
    assert cascade.batch_first is False
    cascade.verdict(_problem(FAMILIAR))
    assert cascade.batch_first is True


def test_an_unfamiliar_plan_says_what_the_guard_did_in_the_plan_commands_text(cascade):
    """The plan JSON's ``guard`` and the plan command's line say that the assembly was found
    unfamiliar and what was done."""
    from rich.console import Console

    from rap.commands._plan_output import print_result
    from rap.plan import plan
    from rap.plan.scoring.cache import ScoreCache

    got = plan(generate(*UNFAMILIAR), model=cascade, cache=ScoreCache())
    guard = got.to_json()["guard"]
    assert guard["unfamiliar"] is True and guard["operations"] == 64
    console = Console(record=True, width=400)
    print_result(console, got)
    text = console.export_text()
    assert (f"unfamiliar assembly: {guard['outside']:.0%} of 64 sampled operations lie far from "
            f"the training data (flagged beyond 40%): {guard['action']}") in text


@pytest.mark.slow
def test_unfamiliar_plan_says_so_and_reaches_095_of_the_optimum():
    from rap.plan import plan
    from rap.plan.scoring.cache import ScoreCache

    asm = generate(*UNFAMILIAR)
    cache = ScoreCache()  # shared: scores are content-keyed and seeded
    default = plan(asm, model=OperationPredictor.load(SHIPPED, engine="auto"), cache=cache)
    doc = default.to_json()
    assert doc["guard"]["unfamiliar"] is True and "action" in doc["guard"]
    optimum = plan(asm, method="optimal", cache=cache)
    assert default.robustness >= 0.95 * optimum.robustness


@pytest.mark.slow
def test_familiar_plan_has_no_guard_entry_and_is_unchanged():
    from rap.plan import plan
    from rap.plan.scoring.cache import ScoreCache

    asm = generate(*FAMILIAR)
    with_guard = OperationPredictor.load(SHIPPED, engine="auto")
    without = OperationPredictor.load(SHIPPED, engine="auto")
    without.guard = None
    a = plan(asm, model=with_guard, cache=ScoreCache())
    b = plan(asm, model=without, cache=ScoreCache())
    assert "guard" not in a.to_json()
    assert [s.to_json() for s in a.steps] == [s.to_json() for s in b.steps]
    assert a.robustness == b.robustness
