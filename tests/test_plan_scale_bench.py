"""benchmarks/plan_scale.py: its assemblies are valid, of the stated size and kind, and seeded.

The generators are the part of the benchmark worth testing: every assembly it builds has exactly the
asked part count, integer coordinates, is valid and comes apart (``rap.geometry.families.verify``),
and a rerun builds the same parts. The ``--quick`` smoke run (planning three 6-7 part assemblies)
is marked slow. No timing is asserted.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from rap.geometry.families import verify

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("plan_scale", ROOT / "benchmarks" / "plan_scale.py")
ps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ps)

CASES = [("herringbone", 7), ("herringbone", 18), ("herringbone", 36), ("wall", 12), ("wall", 22),
         ("grid", 9), ("grid", 12), ("grid", 25), ("convex", 12), ("convex", 7),
         ("tiling", 12), ("polyomino", 10), ("knobs", 12), ("packing", 8)]


def _parts(asm):
    return [(p.id, p.outer) for p in asm.parts]


@pytest.mark.parametrize("kind,n", CASES)
def test_every_assembly_is_valid_of_its_size_and_seeded(kind, n):
    asm = ps.build(kind, n)
    assert len(asm) == n
    verify(asm)  # integer vertices, valid, and a full decomposition
    assert _parts(ps.build(kind, n)) == _parts(asm)


def test_the_default_sizes_span_7_to_100_parts_over_six_kinds():
    sizes = {n for ns in ps.DEFAULT_SIZES.values() for n in ns}
    assert min(sizes) == 7 and max(sizes) == 100 and len(ps.DEFAULT_SIZES) >= 6
    assert {18, 22, 25, 30, 36, 44, 49, 60, 100} <= sizes
    assert all(ps.wall_shape(n) for n in ps.DEFAULT_SIZES["wall"])
    assert all(ps.convex_shape(n) for n in ps.DEFAULT_SIZES["convex"])
    assert max(ps.DEFAULT_SIZES["packing"]) == max(ps.DEFAULT_SIZES["polyomino"]) == 40  # largest


def test_herringbone_is_a_connected_patch_of_two_by_one_bricks():
    asm = ps.herringbone(36, seed=3)
    boxes = []
    for p in asm.parts:
        xs, ys = [x for x, _ in p.outer], [y for _, y in p.outer]
        w, h = max(xs) - min(xs), max(ys) - min(ys)
        assert len(p.outer) == 4 and {w, h} == {2 * ps.BRICK, ps.BRICK}
        boxes.append((min(xs), min(ys), max(xs), max(ys)))
    seen, todo = {0}, [0]
    while todo:
        i = todo.pop()
        for j, b in enumerate(boxes):
            if j not in seen and ps._touch(boxes[i], b):
                seen.add(j)
                todo.append(j)
    assert len(seen) == len(boxes)
    assert _parts(ps.herringbone(36, seed=4)) != _parts(asm)  # the seed moves the centre


def test_shapes_of_the_issue_sizes_and_sizes_a_kind_cannot_build():
    assert ps.wall_shape(22) == (4, 5) and ps.wall_shape(44) == (8, 5)
    assert ps.wall_shape(100) == (8, 12)
    assert ps.convex_shape(30) == {"rows": 5, "cols": 6, "cell": "quad"}
    assert ps.convex_shape(60)["cell"] == "quad"
    for kind, n in (("knobs", 11), ("polyomino", 41), ("packing", 41)):
        with pytest.raises(ValueError):
            ps.build(kind, n)
    assert isinstance(ps.assemblies_for(["knobs"], [11])[0][2], str)  # skipped, with the reason


@pytest.mark.slow
def test_the_quick_run_plans_every_assembly_with_every_method(tmp_path, capsys):
    rows = ps.main(["--quick", "--json", str(tmp_path / "rows.json")])
    assert len(rows) == sum(len(v) for v in ps.QUICK.values())
    for row in rows:
        assert row["default"]["status"] == row["sim"]["status"] == "found"
        assert row["optimal"] is not None and row["default"]["expected_failures"] >= 0.0
    assert (tmp_path / "rows.json").is_file()
    assert "up to 12 parts" in capsys.readouterr().out
