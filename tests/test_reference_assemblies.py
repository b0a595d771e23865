"""The six reference assemblies: valid, feasible, shipped in the package unchanged."""

from pathlib import Path

import pytest

import rap
from rap.io import load_assembly
from rap.geometry.andor import and_or_graph
from rap.geometry.ndbg import build_ndbg
from rap.geometry.partitions import online_partitions

ROOT = Path(__file__).resolve().parents[1]
NAMES = ["hexagon", "mixed-square", "pentagons", "rectilinear", "grid", "triangles"]


@pytest.mark.parametrize("name", NAMES)
def test_reference_assembly_is_valid_and_feasible(name):
    asm = load_assembly(ROOT / "assemblies" / f"{name}.json")
    assert 5 <= len(asm) <= 12
    assert all(x.denominator == 1 and y.denominator == 1 for p in asm.parts for x, y in p.outer)
    graph = and_or_graph(build_ndbg(asm), mode="online")
    assert not graph.interlocked
    assert online_partitions(build_ndbg(asm), frozenset(asm.ids))


@pytest.mark.parametrize("name", NAMES)
def test_packaged_copy_matches_checkout(name):
    packaged = Path(rap.__file__).resolve().parent / "data" / "assemblies" / f"{name}.json"
    assert packaged.read_text() == (ROOT / "assemblies" / f"{name}.json").read_text()


def test_triangles_need_a_non_linear_step():
    """The inverted triangles are each locked by their three neighbours: removing one alone is
    impossible, so some operation must insert a subassembly of several parts at once."""
    asm = load_assembly(ROOT / "assemblies" / "triangles.json")
    ndbg = build_ndbg(asm)
    whole = frozenset(asm.ids)
    singles = {p.moving for p in online_partitions(ndbg, whole) if len(p.moving) == 1}
    assert "t1" not in {next(iter(m)) for m in singles}
    graph = and_or_graph(ndbg, mode="all")
    assert any(len(p.moving) >= 2 and len(p.fixed) >= 2
               for parts in graph.partitions.values() for p in parts)


def test_rectilinear_peg_enters_its_c_part_in_one_direction_only():
    """The peg-in-hole step: with the C-shaped part fixed, the peg has a single feasible direction."""
    asm = load_assembly(ROOT / "assemblies" / "rectilinear.json")
    parts = online_partitions(build_ndbg(asm), frozenset({"peg", "c-part"}))
    peg_moves = [p for p in parts if p.moving == {"peg"}]
    assert peg_moves and all(p.span == "vertex" for p in peg_moves)
