"""Reading assembly JSON (rap.assembly_reader): exact decimals, ring normalisation, the input
bounds checked before any arithmetic, bad files refused in one line."""

from __future__ import annotations

import re
from fractions import Fraction

import pytest

from rap.assembly import LIMITS, AssemblyError, signed_area2
from rap.io import load_assembly, parse_assembly


def _sq(x, y, s=1):
    return [[x, y], [x + s, y], [x + s, y + s], [x, y + s]]


def test_decimals_are_exact(tmp_path):
    p = tmp_path / "d.json"
    p.write_text('{"parts": [{"id": "a", "polygon": [[0, 0], [0.1, 0], [0.1, 0.2], [0, 0.2]]}]}')
    a = load_assembly(p)
    assert a.name == "d"
    assert a.parts[0].outer[1] == (Fraction(1, 10), 0)
    assert a.parts[0].area() == Fraction(1, 50)


def test_rings_are_normalised():
    cw = list(reversed(_sq(0, 0, 4)))
    a = parse_assembly({"parts": [{"id": "a", "polygon": cw, "holes": [_sq(1, 1)]}]})
    p = a.parts[0]
    assert signed_area2(p.outer) > 0 and signed_area2(p.holes[0]) < 0
    assert p.area() == 15


def test_closed_ring_is_tolerated():
    ring = _sq(0, 0) + [[0, 0]]
    assert len(parse_assembly({"parts": [{"id": "a", "polygon": ring}]}).parts[0].outer) == 4


def test_missing_file(tmp_path):
    with pytest.raises(AssemblyError, match="no such file"):
        load_assembly(tmp_path / "nope.json")


# -- input bounds (rap.assembly.LIMITS) ----------------------------------------------------------

def _file_with(tmp_path, number: str):
    p = tmp_path / "n.json"
    p.write_text('{"parts": [{"id": "a", "polygon": [[0, 0], [%s, 0], [0, 1]]}]}' % number)
    return p


@pytest.mark.timeout(30)  # the harness's bound: the old reader ran for hours on the first two
@pytest.mark.parametrize("number,problem", [
    ("1e-1000000", "coordinate 1E-1000000 has more than 6 digits after the point"),
    ("1e10000000", "coordinate 1E+10000000 is out of range (|x| <= 10^9)"),
    ("-1e10000000", "coordinate -1E+10000000 is out of range"),
    ("1000000000.5", "coordinate 1000000000.5 is out of range"),
    ("1000000001", "coordinate 1000000001 is out of range"),
    ("9" * 4000, "coordinate 9999999999999999999999999999999999999... is out of range"),
    ("9" * 5000, "not valid JSON: a number with more than 4300 digits"),
    ("0.0000001", "coordinate 1E-7 has more than 6 digits after the point"),
    ("0." + "0" * 100000 + "1", "has more than 6 digits after the point"),
    ("1e309", "coordinate 1E+309 is out of range"),
])
def test_a_coordinate_past_the_bounds_is_refused_before_any_arithmetic(tmp_path, number, problem):
    path = _file_with(tmp_path, number)
    with pytest.raises(AssemblyError) as err:
        load_assembly(path)
    assert str(err.value).startswith(f"{path}: ") and problem in str(err.value), str(err.value)
    assert len(str(err.value)) < 300


@pytest.mark.parametrize("number,value", [
    ("1e9", Fraction(10**9)), ("-1000000000", Fraction(-10**9)), ("999999999.999999",
     Fraction(999999999999999, 10**6)), ("0.000001", Fraction(1, 10**6)),
    ("2.500000000000000000000000000", Fraction(5, 2)), ("1." + "0" * 100000, Fraction(1)),
    ("0e99999999", Fraction(0)), ("-0.0", Fraction(0)), ("12.5e-5", Fraction(125, 10**6)),
])
def test_a_coordinate_at_the_bounds_is_read_exactly(tmp_path, number, value):
    p = tmp_path / "n.json"
    p.write_text('{"parts": [{"id": "a", "polygon": [[-5, -5], [5, -5], [0, %s]]}]}' % number)
    a = load_assembly(p)
    assert (0, value) in a.parts[0].outer


def _square_part(i: int) -> dict:
    return {"id": f"p{i}", "polygon": _sq(2 * i, 0)}


@pytest.mark.parametrize("doc,problem", [
    ({"parts": [_square_part(i) for i in range(LIMITS.max_parts + 1)]},
     "1001 parts; at most 1000 are read"),
    ({"parts": [{"id": "a", "polygon": [[i, i * i] for i in range(10_001)]}]},
     "part 'a': polygon has 10001 vertices; at most 10000 are read"),
    ({"parts": [{"id": "a", "polygon": _sq(0, 0, 1000), "holes": [_sq(3 * i + 1, 1)
                                                                for i in range(101)]}]},
     "part 'a': 101 holes; at most 100 are read"),
    ({"parts": [{"id": f"p{k}", "polygon": [[k * 10**5 + i, i * i % 97] for i in range(9_000)]}
                for k in range(12)]},
     "part 'p11': the assembly has more than 100000 vertices in all"),
    ({"parts": [{"id": "x" * 101, "polygon": _sq(0, 0)}]}, "at most 100 characters"),
])
def test_an_assembly_past_the_size_bounds_is_refused(doc, problem):
    with pytest.raises(AssemblyError, match=re.escape(problem)):
        parse_assembly(doc, source="big")


def test_a_file_past_16_mib_and_binary_files_are_refused_in_one_line(tmp_path):
    big = tmp_path / "big.json"
    big.write_text('{"parts": []}' + " " * (16 << 20))
    with pytest.raises(AssemblyError, match=r"big\.json: file over 16 MiB"):
        load_assembly(big)
    png = tmp_path / "picture.json"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    with pytest.raises(AssemblyError) as exc:
        load_assembly(png)
    assert str(exc.value) == f"{png}: is a PNG image, not an assembly (JSON, DXF or SVG)"
    latin = tmp_path / "latin.json"
    latin.write_bytes(b'{"name": "caf\xe9"}')
    with pytest.raises(AssemblyError) as exc:
        load_assembly(latin)
    assert str(exc.value) == (f"{latin}: not UTF-8 text (byte 13), so not an assembly (JSON, DXF "
                              f"or SVG)")
    nested = tmp_path / "nested.json"
    nested.write_text("[" * 1_000_000 + "]" * 1_000_000)
    with pytest.raises(AssemblyError, match="nested too deeply"):
        load_assembly(nested)
