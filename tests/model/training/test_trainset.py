"""rap.model.training.trainset: what a training run learns from (the calibration split here; the other
steps through ``train`` in test_train.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rap.errors import ParameterError
from rap.model.training.trainset import check_holdouts, in_memory_store, split_validation


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


def test_unknown_holdouts_name_the_parameter(tiny_dataset):
    """The library speaks of ``holdout`` / ``holdout_family`` (``rap-farm train`` of its flags)."""
    root = str(Path(tiny_dataset).resolve())
    with pytest.raises(ParameterError) as err:
        check_holdouts(root, None, "nope", None)
    assert err.value.parameter == "holdout"
    assert str(err.value) == f"holdout nope: no such assembly in {root} (has: alpha, beta, gamma)"
    with pytest.raises(ParameterError) as err:
        check_holdouts(root, None, None, "castles")
    assert err.value.parameter == "holdout_family"
    assert str(err.value) == f"holdout_family castles: no such family in {root} (has: custom)"


def test_a_sample_of_a_dataset_too_large_for_memory_names_max_rows(tiny_dataset):
    with pytest.raises(ParameterError) as err:
        in_memory_store(str(tiny_dataset), None, max_memory_mb=0.0, max_rows=10)
    assert err.value.parameter == "max_rows"
    assert str(err.value) == ("max_rows 10: needs the dataset in memory (144 rows exceed "
                              "max_memory_mb 0)")
    assert in_memory_store(str(tiny_dataset), None, max_memory_mb=0.0) is None  # streamed


def test_held_out_shape_kinds_never_enter_a_training_selection():
    from rap.geometry.families import HELD_OUT
    from rap.model.training.trainset import training_selection

    for family in (None, "hub"):
        sel, _ = training_selection("datasets/corpus", None, None, family)
        assert HELD_OUT <= set(sel.exclude_families)
        assert family is None or family in sel.exclude_families
