"""research/validation_tables.py: the assembly splits as data (datasets/splits.json), consistent
with the corpus and the assembly files, and search replayed on a score table."""

from __future__ import annotations

import numpy as np
import pytest

from rap.geometry.families import FAMILIES
from rap.plan.graph import reachable

from research import validation_tables as vt
from tests.scripts import load_script


def test_the_splits_name_existing_assemblies_and_do_not_overlap():
    splits = vt.load_splits()
    assert len(vt.TEST) == 14 and len(vt.VALIDATION) == 27 and len(vt.UNSEEN) == 12
    assert not set(vt.TEST) & set(vt.VALIDATION)
    assert not set(vt.UNSEEN) & (set(vt.TEST) | set(vt.VALIDATION))
    for name in vt.TEST + vt.VALIDATION + vt.UNSEEN:
        assert vt.assembly_path(name).is_file(), name
    for name in vt.UNSEEN:
        assert vt.assembly_path(name).parent.name == "unseen"
    reference = sorted(p.stem for p in (vt.ROOT / "assemblies").glob("*.json"))
    assert splits["train"]["reference"] == reference
    corpus = load_script("make_corpus")
    assert splits["train"]["seeds"] == corpus.SEEDS
    for name in vt.VALIDATION:  # generated corpus assemblies of a family with a hold-out model
        family, seed = name.rsplit("-s", 1)
        assert family in FAMILIES and int(seed) < corpus.SEEDS
    assert vt.FRESH_FROM >= 200 and vt.FRESH_PARTS == (7, 10)


def test_assemblies_of_names_each_split():
    assert vt.assemblies_of("test") == vt.TEST and vt.assemblies_of("unseen") == vt.UNSEEN
    assert vt.assemblies_of("validation") == vt.VALIDATION
    with pytest.raises(KeyError):
        vt.assemblies_of("train")


def test_search_with_perfect_predictions_finds_the_optimum_on_a_table():
    problem = vt.problem_of("rectilinear")
    graph = reachable(problem)
    keys = sorted({problem.key(op) for c in graph.values() for op in c})
    rng = np.random.default_rng(5)
    truth = dict(zip(keys, (rng.integers(60, 101, len(keys)) / 100).tolist()))
    ratio, simulations = vt.evaluate("rectilinear", {"pred": truth, "truth": truth}, None, 0)
    assert ratio == pytest.approx(1.0, abs=1e-12) and simulations == 0
    metrics = vt.prediction_metrics("rectilinear", {"pred": truth, "truth": truth})
    assert metrics["accuracy"] == 1.0 and metrics["mae"] == 0.0 and metrics["pair_order"] == 1.0
