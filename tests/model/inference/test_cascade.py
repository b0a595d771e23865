"""The default scorer (rap.model.inference.cascade): what OperationPredictor.load gives, the
band's rule, agreement with the CNN alone where the CNN is asked, batching independence."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import rap
from rap.io import load_assembly
from rap.model.inference.cascade import CascadeScorer, companion, load_default
from rap.model.inference.descriptor_model import DescriptorModel
from rap.model.inference.operations import OperationPredictor
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

DATA = Path(rap.__file__).parent / "data"
SHIPPED = DATA / "default_model.pt"


@pytest.fixture(scope="module")
def problem_ops():
    problem = PlanningProblem(load_assembly(DATA / "assemblies" / "hexagon.json"), SimParams())
    return problem, list(problem.candidates(problem.whole))[:24]


def test_load_auto_is_the_cascade_and_cnn_is_the_cnn_alone():
    auto = OperationPredictor.load(SHIPPED, engine="auto")
    assert isinstance(auto, CascadeScorer)
    assert isinstance(OperationPredictor.load(SHIPPED, engine="cnn"), OperationPredictor)
    assert isinstance(OperationPredictor.load(SHIPPED, engine="auto", mirror=True),
                      OperationPredictor)
    assert auto.meta == auto.cnn.meta  # the plan command's familiarity check reads these


def test_band_rule_and_agreement_with_the_cnn(problem_ops):
    problem, ops = problem_ops
    cnn = OperationPredictor.load(SHIPPED, engine="cnn")
    want_p, want_e = cnn.prob_high_and_expected(problem, ops)
    everywhere = CascadeScorer(cnn, load_default(SHIPPED, cnn).model, band=(-1.0, 2.0))
    p, e = everywhere.prob_high_and_expected(problem, ops)
    np.testing.assert_allclose(p, want_p, atol=1e-6)
    np.testing.assert_allclose(e, want_e, atol=1e-6)
    assert everywhere.counts == {"descriptors": 0, "cnn": len(ops)}
    alone = CascadeScorer(cnn, everywhere.model, band=(0.5, 0.5))
    p2, e2 = alone.prob_high_and_expected(problem, ops)
    assert alone.counts == {"descriptors": len(ops), "cnn": 0}
    d = alone.descriptors(problem, ops)
    np.testing.assert_allclose((p2, e2), everywhere.model.prob_high_and_expected(d))
    mid = CascadeScorer(cnn, everywhere.model, band=(0.2, 0.8))
    p3, e3 = mid.prob_high_and_expected(problem, ops)
    inside = (p2 > 0.2) & (p2 < 0.8)
    np.testing.assert_allclose(np.where(inside, want_e, e2), e3, atol=1e-6)
    assert mid.counts["cnn"] == inside.sum()


def test_batch_first_only_when_no_operation_reaches_the_cnn():
    cnn = OperationPredictor.load(SHIPPED, engine="cnn")
    model = load_default(SHIPPED, cnn).model
    assert CascadeScorer(cnn, model, band=(0.5, 0.5)).batch_first  # the trees alone
    assert not CascadeScorer(cnn, model, band=(0.2, 0.8)).batch_first
    assert OperationPredictor.load(SHIPPED, engine="auto").batch_first  # the shipped band


def test_batching_changes_nothing(problem_ops):
    problem, ops = problem_ops
    scorer = OperationPredictor.load(SHIPPED, engine="auto")
    whole = scorer.expected_score(problem, ops)
    parts = np.concatenate([scorer.expected_score(problem, ops[i:i + 3])
                            for i in range(0, len(ops), 3)])
    np.testing.assert_allclose(parts, whole, atol=1e-9)
    np.testing.assert_allclose(scorer.prob_high(problem, ops),
                               scorer.prob_high_and_expected(problem, ops)[0])
    assert scorer.expected_score(problem, []).shape == (0,)


def test_a_descriptor_model_for_another_checkpoint_is_not_used(tmp_path, monkeypatch):
    ckpt = tmp_path / "mine.pt"
    ckpt.write_bytes(SHIPPED.read_bytes() + b"")  # same bytes: used
    shutil.copy(companion(SHIPPED), companion(ckpt))
    assert isinstance(OperationPredictor.load(ckpt, engine="auto"), CascadeScorer)
    other = tmp_path / "other.pt"
    shutil.copy(companion(SHIPPED), companion(other))
    shutil.copy(DATA / "default_model.pt", other)
    with open(other, "ab") as f:  # another file (a trailing byte): the CNN alone
        f.write(b"\0")
    assert load_default(other, None) is None
    loads = []  # the checksum is checked before the trees are read: they never are
    monkeypatch.setattr(DescriptorModel, "load", classmethod(lambda cls, p: loads.append(p)))
    assert load_default(other, None) is None and loads == []
