"""The assembly model: exact parts, geometry hash, float views, family metadata, the JSON
document written back exactly, what the input bounds promise."""

from __future__ import annotations

import json
import math
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rap
from rap.assembly import SHIPPED_ASSEMBLIES, AssemblyError, assembly_to_json, signed_area2
from rap.io import load_assembly, parse_assembly


def _sq(x, y, s=1):
    return [[x, y], [x + s, y], [x + s, y + s], [x, y + s]]


def test_signed_area2_is_exact_and_signed_by_orientation():
    ring = [(Fraction(0), Fraction(0)), (Fraction(1, 10), Fraction(0)), (Fraction(0), Fraction(1, 3))]
    assert signed_area2(ring) == Fraction(1, 30)
    assert signed_area2(ring[::-1]) == -Fraction(1, 30)


def test_round_trip_of_decimals(tmp_path):
    text = '{"name": "t", "parts": [{"id": "a", "polygon": [[0, 0], [0.1, 0], [0.1, 0.3], [0, 0.3]]}]}'
    a = parse_assembly(json.loads(text, parse_float=Decimal))
    out = tmp_path / "t.json"
    out.write_text(json.dumps(assembly_to_json(a)))
    b = load_assembly(out)
    assert b.parts == a.parts and b.geometry_hash == a.geometry_hash


def test_geometry_hash_ignores_name():
    a = parse_assembly({"name": "x", "parts": [{"id": "a", "polygon": _sq(0, 0)}]})
    b = parse_assembly({"name": "y", "parts": [{"id": "a", "polygon": _sq(0, 0)}]})
    assert a.geometry_hash == b.geometry_hash


def test_validation_runs_on_parse():
    with pytest.raises(AssemblyError, match="overlaps part 'b'"):
        parse_assembly({"parts": [{"id": "a", "polygon": _sq(0, 0, 2)},
                                  {"id": "b", "polygon": _sq(1, 1, 2)}]})
    parse_assembly({"parts": [{"id": "a", "polygon": _sq(0, 0, 2)},
                              {"id": "b", "polygon": _sq(1, 1, 2)}]}, validate=False)


def test_family_is_metadata_read_and_written():
    from rap.assembly_reader import assembly_from_json

    doc = {"name": "w", "family": "wall", "parts": [{"id": "a", "polygon": [[0, 0], [1, 0], [1, 1]]}]}
    a = assembly_from_json(doc)
    assert a.family == "wall" and assembly_to_json(a)["family"] == "wall"
    plain = assembly_from_json({k: v for k, v in doc.items() if k != "family"})
    assert plain.family == "custom" and "family" not in assembly_to_json(plain)
    assert plain == a and plain.geometry_hash == a.geometry_hash  # not part of the content
    with pytest.raises(AssemblyError, match="'family'"):
        assembly_from_json({**doc, "family": "two words"})


def test_reference_assemblies_are_of_the_reference_family():
    from pathlib import Path

    for p in (Path(__file__).resolve().parents[1] / "assemblies").glob("*.json"):
        assert load_assembly(p).family == "reference"


def test_float_views_of_the_rings():
    a = parse_assembly({"parts": [{"id": "a", "polygon": _sq(0, 0, 4), "holes": [_sq(1, 1)]}]})
    p = a.parts[0]
    outer, hole = p.float_arrays()
    assert outer.tolist() == [list(xy) for xy in p.float_outer()]
    assert hole.tolist() == [list(xy) for xy in p.float_holes()[0]]
    assert p.float_arrays()[0] is outer  # built once
    with pytest.raises(ValueError):
        outer[0, 0] = 9.0  # shared: read-only


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.integers(-10**15, 10**15), st.integers(-10**15, 10**15))
def test_distinct_coordinates_within_the_bounds_stay_distinct_and_finite_as_floats(k1, k2):
    """What the bounds promise the physics and the renderer: grid points of 10^-6 up to 10^9
    convert to finite floats, in order, and distinct ones stay distinct (differences too)."""
    x1, x2 = Fraction(k1, 10**6), Fraction(k2, 10**6)
    f1, f2 = float(x1), float(x2)
    assert math.isfinite(f1) and math.isfinite(f2) and math.isfinite(f1 - f2)
    assert (f1 < f2) == (x1 < x2) and (f1 == f2) == (x1 == x2)


def test_the_shipped_assemblies_are_the_package_data():
    assert SHIPPED_ASSEMBLIES == Path(rap.__file__).resolve().parent / "data" / "assemblies"
    assert (SHIPPED_ASSEMBLIES / "hexagon.json").is_file()
