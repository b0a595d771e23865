"""Exact validation: a corpus of bad files through ``rap-farm inspect``, and valid fixtures."""

from __future__ import annotations

import subprocess
import sys
from decimal import Decimal
from pathlib import Path

import pytest

from rap.assembly import AssemblyError
from rap.io import parse_assembly
from rap.geometry.validation import (convex_interiors_overlap, point_in_ring, ring_is_simple,
                                     segments_intersect, validate_assembly)

from .fixtures import VALID, decimals, square

BAD = Path(__file__).parents[1] / "data" / "bad"
BAD_FILES = sorted(BAD.glob("*.json"))

# files whose error must name a part (the part label as printed)
PART_OF = {
    "boolean_coordinate.json": "'a'", "collinear.json": "'a'", "contained_part.json": "'big'",
    "duplicate_ids.json": "'a'", "fold_back.json": "'a'", "hole_crossing.json": "'a'",
    "hole_outside.json": "'a'", "hole_self_intersecting.json": "'a'",
    "hole_touching.json": "'a'", "holes_not_list.json": "'a'", "holes_overlap.json": "'a'",
    "id_with_comma.json": "'#0'", "missing_id.json": "'#0'", "missing_polygon.json": "'a'",
    "non_numeric.json": "'a'", "overlap_decimal.json": "'a'", "overlapping_parts.json": "'a'",
    "part_not_object.json": "'#0'", "point_not_pair.json": "'a'", "repeated_vertex.json": "'a'",
    "self_intersecting.json": "'a'", "self_touching.json": "'a'", "two_vertices.json": "'a'",
    "zero_area_bowtie.json": "'a'",
}


def test_corpus_is_large_enough():
    assert len(BAD_FILES) >= 20


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.name)
def test_bad_file_is_one_line_exit_2(path, run_cli):
    code, out, err = run_cli("inspect", path)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(path) in lines[0]
    assert "Traceback" not in err
    if path.name in PART_OF:
        assert f"part {PART_OF[path.name]}" in lines[0]


def test_bad_file_in_a_subprocess_has_no_traceback():
    path = BAD / "overlapping_parts.json"
    proc = subprocess.run([sys.executable, "-c", "from rap.cli import main; main()", "inspect",
                           str(path), "--json"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "overlapping_parts.json: part 'a': overlaps part 'b'" in proc.stderr


@pytest.mark.parametrize("asm", VALID, ids=lambda a: a.name)
def test_fixtures_are_valid(asm):
    validate_assembly(asm)


def test_decimal_boundaries_stay_touching():
    asm = decimals()  # 0.1 + 0.2 == 0.3 exactly: touching, not overlapping
    validate_assembly(asm)
    # the float sum 0.30000000000000004 is off the input grid (6 decimals): refused on reading,
    # naming the number, before it could overlap the neighbour by 4e-17
    with pytest.raises(AssemblyError, match=r"part 'a': coordinate 0\.30000000000000004 has more "
                                            r"than 6 digits after the point"):
        x = Decimal(repr(0.1 + 0.2))
        three = Decimal("0.3")
        parse_assembly({"parts": [{"id": "a", "polygon": [[0, 0], [x, 0], [three, 1], [0, 1]]},
                                  {"id": "b", "polygon": [[three, 0], [1, 0], [1, 1], [three, 1]]}]})


CASES = [  # (name, parts, problem or None)
    ("touch at a point", [square(0, 0), square(1, 1)], None),
    ("share an edge", [square(0, 0), square(0, 1)], None),
    ("partial edge", [square(0, 0, 2), square(2, 1)], None),
    ("part in a hole", [{"polygon": square(0, 0, 6), "holes": [square(2, 2, 2)]}, square(2, 2, 2)], None),
    ("part over a hole", [{"polygon": square(0, 0, 6), "holes": [square(2, 2, 2)]}, square(1, 1, 2)],
     "overlaps"),
    ("identical", [square(0, 0), square(0, 0)], "overlaps"),
    ("triangle crosses", [[[0, 0], [4, 0], [0, 4]], [[1, 1], [5, 1], [5, 5]]], "overlaps"),
    ("nested non-convex", [[[0, 0], [6, 0], [6, 6], [4, 6], [4, 2], [2, 2], [2, 6], [0, 6]],
                           square(2, 2, 2)], None),
    ("nested non-convex overlap", [[[0, 0], [6, 0], [6, 6], [4, 6], [4, 2], [2, 2], [2, 6], [0, 6]],
                                   square(2, 1, 2)], "overlaps"),
]


@pytest.mark.parametrize("name,parts,problem", CASES, ids=[c[0] for c in CASES])
def test_overlap_cases(name, parts, problem):
    data = {"parts": [dict(p, id=f"p{k}") if isinstance(p, dict) else {"id": f"p{k}", "polygon": p}
                      for k, p in enumerate(parts)]}
    if problem is None:
        parse_assembly(data)
    else:
        with pytest.raises(AssemblyError, match=problem):
            parse_assembly(data)


def test_predicates():
    assert segments_intersect((0, 0), (2, 2), (0, 2), (2, 0))
    assert segments_intersect((0, 0), (2, 0), (2, 0), (3, 5))  # touching end
    assert segments_intersect((0, 0), (4, 0), (1, 0), (2, 0))  # collinear overlap
    assert not segments_intersect((0, 0), (1, 0), (2, 0), (3, 0))
    assert not segments_intersect((0, 0), (1, 1), (1, 0), (2, 0))
    assert ring_is_simple([(0, 0), (2, 0), (2, 2), (0, 2)])
    assert not ring_is_simple([(0, 0), (2, 0), (0, 2), (2, 2)])
    sq = [(0, 0), (4, 0), (4, 4), (0, 4)]
    assert point_in_ring((1, 1), sq) == 1 and point_in_ring((4, 2), sq) == 0
    assert point_in_ring((5, 2), sq) == -1 and point_in_ring((0, 0), sq) == 0
    assert not convex_interiors_overlap(sq, [(4, 0), (8, 0), (8, 4), (4, 4)])
    assert not convex_interiors_overlap(sq, [(4, 4), (5, 4), (5, 5)])
    assert convex_interiors_overlap(sq, [(3, 3), (5, 3), (5, 5)])
