import csv
import math
from dataclasses import replace

import numpy as np
import pytest

from tests.model.model_fixtures import FAST_TRAIN, LEARN_MODEL
from rap.errors import InputError
from rap.model.evaluation.cross_validation import cross_validate, fold_specs, summary_rows, write_report
from rap.model.evaluation.metrics import classification_metrics, expected_calibration_error, reliability_table


def test_metrics_per_class_and_calibration():
    labels = np.array([0, 0, 0, 1, 1])
    prob = np.array([0.1, 0.6, 0.05, 0.95, 0.4])
    m = classification_metrics(labels, prob)
    assert m["accuracy"] == pytest.approx(3 / 5)
    assert m["low_accuracy"] == pytest.approx(2 / 3) and m["high_accuracy"] == pytest.approx(1 / 2)
    table = reliability_table(m["reliability"])
    assert sum(b["rows"] for b in table) == 5 and table[9]["frac_high"] == 1.0
    # bins 0 (0.1, 0.05: no high), 4 (0.4: high), 6 (0.6: not high), 9 (0.95: high)
    expected = (0.075 * 2 + 0.6 + 0.6 + 0.05) / 5
    assert m["ece"] == pytest.approx(expected)
    assert math.isnan(classification_metrics(np.array([0]), np.array([0.2]))["high_accuracy"])
    assert expected_calibration_error(classification_metrics(labels, labels * 1.0)["reliability"]) == 0


def test_leave_one_assembly_out_learns_the_rule(learnable_dataset, tmp_path):
    """Wide moving blocks are high, narrow ones not: held-out assemblies are classified > 90%."""
    specs = fold_specs(learnable_dataset, LEARN_MODEL, replace(FAST_TRAIN, epochs=6),
                       models_dir=tmp_path / "models")
    folds = cross_validate(specs)
    rows = summary_rows(folds)
    assert [r["assembly"] for r in rows] == ["alpha", "beta", "gamma", "mean"]
    assert rows[-1]["accuracy"] > 0.9, rows
    assert all(r["accuracy"] > 0.8 for r in rows), rows
    assert (tmp_path / "models" / "holdout-beta.pt").exists()
    paths = write_report(folds, tmp_path / "report", "synthetic", {"threshold": 0.95})
    assert all(p.exists() and p.stat().st_size for p in paths)
    text = paths[0].read_text()
    assert "| **mean** |" in text and "Expected calibration error" in text
    with open(paths[1]) as fh:
        table = list(csv.DictReader(fh))
    assert table[-1]["assembly"] == "mean"
    assert float(table[-1]["accuracy"]) == pytest.approx(rows[-1]["accuracy"])


def test_noise_ceiling_is_one_far_from_the_threshold_and_lower_near_it():
    from rap.model.evaluation.metrics import noise_ceiling

    assert noise_ceiling(np.array([0, 10, 50]), np.array([100] * 3), 0.95) == pytest.approx(1.0, abs=1e-6)
    near = noise_ceiling(np.array([94, 95, 96]), np.array([100] * 3), 0.95)
    assert 0.7 < near < 0.8
    m = classification_metrics(np.array([1, 0]), np.array([0.9, 0.1]), np.array([100, 20]),
                               np.array([100, 100]))
    assert m["accuracy"] == 1.0 and m["ceiling"] > 0.99


def test_leave_one_family_out_folds_and_report(family_dataset, tmp_path):
    from rap.model.training.train import train

    specs = (fold_specs(family_dataset, LEARN_MODEL, replace(FAST_TRAIN, epochs=2), ["ref"])
             + fold_specs(family_dataset, LEARN_MODEL, replace(FAST_TRAIN, epochs=2),
                          ["walls", "pegs"], kind="family", models_dir=tmp_path / "m"))
    folds = cross_validate(specs)
    assert [(f["kind"], f["assembly"]) for f in folds] == [
        ("assembly", "ref"), ("family", "pegs"), ("family", "walls")]
    walls = folds[2]
    assert walls["metrics"]["rows"] == 2 * 96  # both of the family's assemblies are tested
    assert walls["train"]["rows"] == 3 * 96  # and neither is trained on
    assert set(walls["metrics"]["per_assembly"]) == {"alpha", "beta"}
    assert 0.5 < walls["metrics"]["ceiling"] <= 1.0
    assert (tmp_path / "m" / "holdout-family-walls.pt").exists()
    paths = write_report(folds, tmp_path / "report", "families", {"threshold": 0.95})
    text = paths[0].read_text()
    assert "## Leave one assembly out" in text and "## Leave one family out" in text
    assert "| Test family |" in text and "Ceiling" in text
    assert {p.name for p in paths} >= {"crossval.png", "crossval-family.png"}
    with pytest.raises(InputError, match=r"holdout.family fans: no such family in .+ \(has: "
                                          r"pegs, reference, walls\)$"):
        train(family_dataset, holdout_family="fans", model_config=LEARN_MODEL, config=FAST_TRAIN)


def test_binomial_head_with_calibration_learns_and_scores(family_dataset, tmp_path):
    from rap.model.network.cnn import ModelConfig
    from rap.model.evaluation.cross_validation import score_checkpoint
    from rap.model.inference.torch_engine import TorchPredictor
    from rap.model.training.train import train

    cfg = replace(LEARN_MODEL, norm="batch", head="binomial")
    res = train(family_dataset, holdout="ref", model_config=cfg,
                config=replace(FAST_TRAIN, epochs=6, calibrate=True, augment="hflip",
                               schedule="cosine"))
    assert res.calibration is not None and res.calibration["temperature"] > 0
    assert len(res.calibration["assemblies"]) == 1 and "ref" not in res.calibration["assemblies"]
    assert res.metrics["train"]["rows"] == 3 * 96  # the calibration assembly is not trained on
    assert res.metrics["holdout"]["accuracy"] > 0.8
    path = res.save(tmp_path / "b.pt")
    pred = TorchPredictor.load(path)
    assert pred.head == "binomial" and pred.temperature == res.calibration["temperature"]
    rows = score_checkpoint(path, family_dataset, by="family")
    assert [r["family"] for r in rows] == ["pegs", "reference", "walls", "all"]
    assert rows[1]["accuracy"] == pytest.approx(res.metrics["holdout"]["accuracy"])
    only = score_checkpoint(path, family_dataset, by="family", only=["reference"])
    assert [r["family"] for r in only] == ["reference", "all"]  # the other families' rows are skipped
    assert only[0] == rows[1] and only[1]["rows"] == rows[1]["rows"]
    assert ModelConfig.from_dict(pred.config.to_dict()) == cfg
