import csv
import math
from dataclasses import replace

import numpy as np
import pytest

from model_fixtures import FAST_TRAIN, LEARN_MODEL
from rap.model.evaluate import cross_validate, fold_specs, summary_rows, write_report
from rap.model.metrics import classification_metrics, expected_calibration_error, reliability_table


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
