"""The benchmark of assemblies no model was trained on (scripts/make_unseen.py): valid, feasible,
exact, none of them in the corpus, and exactly what the script writes."""

import json
from pathlib import Path

import pytest

from rap.geometry.andor import and_or_graph
from rap.geometry.ndbg import build_ndbg
from rap.io import load_assembly

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[1]
FILES = sorted((ROOT / "assemblies" / "unseen").glob("*.json"))


def _script():
    return load_script("make_unseen")


def test_thirteen_assemblies_three_new_kinds_and_ten_fresh_seeds():
    names = {f.stem for f in FILES}
    assert len(FILES) == 13 and {"tangram", "pentomino-6x10", "basketweave"} <= names
    fresh = sorted(n.rsplit("-s", 1)[0] for n in names if "-s" in n)
    from rap.geometry.families import FAMILIES

    assert fresh == sorted(FAMILIES)


@pytest.fixture(scope="module")
def corpus_hashes():
    return {load_assembly(p, validate=False).geometry_hash
            for p in (ROOT / "datasets" / "corpus" / "_assemblies").glob("*.json")}


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_valid_feasible_exact_and_not_in_the_corpus(path, corpus_hashes):
    asm = load_assembly(path)
    assert 7 <= len(asm) <= 12
    assert all(x.denominator == 1 and y.denominator == 1 for p in asm.parts for x, y in p.outer)
    assert not and_or_graph(build_ndbg(asm), mode="online").interlocked
    assert asm.geometry_hash not in corpus_hashes


def test_pentomino_tiling_covers_the_rectangle_with_the_twelve_pieces():
    tiling = _script().pentomino_tiling()
    cells = [c for piece in tiling.values() for c in piece]
    assert sorted(tiling) == sorted("FILNPTUVWXYZ")
    assert sorted(cells) == sorted((x, y) for x in range(10) for y in range(6))


def test_the_script_writes_the_committed_files(tmp_path, monkeypatch):
    mod = _script()
    monkeypatch.setattr(mod, "OUT_DIR", tmp_path)
    written = mod.make_assemblies()
    assert sorted(p.name for p in written) == [f.name for f in FILES]
    for p in written:
        committed = ROOT / "assemblies" / "unseen" / p.name
        assert json.loads(p.read_text()) == json.loads(committed.read_text())
