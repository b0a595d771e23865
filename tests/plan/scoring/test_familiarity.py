"""The warning that an assembly looks unlike the model's training data: quiet on every assembly
the shipped model was trained on, loud on images unlike its training images."""

from __future__ import annotations

import numpy as np
import pytest

from rap.io import load_assembly
from rap.model.inference.operations import OperationPredictor
from rap.plan.scoring.familiarity import (FAMILIARITY_OPERATIONS, familiarity_operations,
                                  foreground_stats, model_familiarity)
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

from tests.plan.cases import ROOT, six

SHIPPED = ROOT / "rap" / "data" / "default_model.pt"
CORPUS_ASSEMBLIES = ROOT / "datasets" / "corpus" / "_assemblies"


@pytest.fixture(scope="module")
def cnn():
    return OperationPredictor.load(SHIPPED, engine="auto")


def unlike(notes):
    return [n for n in notes if "looks unlike" in n]


def test_operations_breadth_first_from_the_whole_each_subassembly_once():
    problem = PlanningProblem(six("hexagon"), SimParams())
    ops = familiarity_operations(problem)
    top = problem.candidates(problem.whole)
    assert len(ops) == FAMILIARITY_OPERATIONS and tuple(ops[:len(top)]) == top
    assert len({problem.key(op) for op in ops}) == len(ops)  # no subassembly visited twice
    assert familiarity_operations(problem) == ops  # deterministic
    assert familiarity_operations(problem, limit=3) == ops[:3]


def test_quiet_on_every_assembly_the_shipped_model_was_trained_on(cnn):
    trained = cnn.meta["assemblies"]
    assert len(trained) > 300
    loud = []
    for entry in trained:
        a = load_assembly(CORPUS_ASSEMBLIES / f"{entry['name']}.json")
        problem = PlanningProblem(a, SimParams())
        notes = model_familiarity(cnn.meta, a.geometry_hash,
                                  cnn.images(problem, familiarity_operations(problem)))
        assert any("was in the model's training data" in n for n in notes), entry["name"]
        loud += [entry["name"]] * bool(unlike(notes))
    assert loud == []


def test_loud_on_images_unlike_the_training_images(cnn):
    problem = PlanningProblem(six("grid"), SimParams())
    images = np.asarray(cnn.images(problem, familiarity_operations(problem)))
    assert unlike(model_familiarity(cnn.meta, "not-trained", images)) == []
    notes = model_familiarity(cnn.meta, "not-trained", np.full_like(images, 255))  # all foreground
    assert len(unlike(notes)) == 1 and "z-scores" in notes[0]
    assert not any("training data:" in n for n in model_familiarity(cnn.meta, "x", images))


def test_foreground_stats_match_the_training_statistics():
    pytest.importorskip("pyarrow")
    from rap.model.data.rows import image_stats

    problem = PlanningProblem(six("triangles"), SimParams())
    images = OperationPredictor(None).images(problem, problem.candidates(problem.whole))
    ref = image_stats([images])
    new = foreground_stats(images)
    np.testing.assert_allclose(new["foreground_mean"], ref["foreground_mean"])
    np.testing.assert_allclose(new["coarse_foreground"], ref["coarse_foreground"], atol=1e-5)
