"""rap.model.trainset: what a training run learns from (the calibration split here; the other
steps through ``train`` in test_train.py)."""

from __future__ import annotations

from rap.model.trainset import split_validation


def test_calibration_split_by_assemblies_or_by_rows():
    names = [f"a{i:02d}" for i in range(40)] + ["huge"]
    rows = {n: 100 for n in names} | {"huge": 3000}  # 7,000 rows, 3,000 of them in one assembly
    by_count = split_validation(names, 0.1, 0)
    assert len(by_count) == 4 and by_count == split_validation(names, 0.1, 0)
    by_rows = split_validation(names, 0.1, 0, rows)
    assert "huge" not in by_rows and sum(rows[n] for n in by_rows) == 700  # a tenth of the rows
    assert by_rows == split_validation(names, 0.1, 0, rows)
    assert by_rows != split_validation(names, 0.1, 1, rows)
    # nothing fits: the smallest; never all; too few assemblies: none
    assert split_validation(["x", "y", "z"], 0.1, 0, {"x": 5, "y": 3, "z": 9}) == ["y"]
    assert split_validation(["x", "y"], 0.5, 0, {"x": 1, "y": 1}) == []
