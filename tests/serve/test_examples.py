"""The page's example assemblies without a service: the package's own files, read once, and only
their names looked up (``rap.serve.examples``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import rap
from rap.assembly import assembly_to_json
from rap.errors import InputError
from rap.io import load_assembly
from rap.serve.examples import EXAMPLES_DIR, UnknownExample, example, example_list


def test_the_examples_are_the_shipped_reference_assemblies():
    # package data (pyproject's package-data), there after pip install
    assert EXAMPLES_DIR == Path(rap.__file__).resolve().parent / "data" / "assemblies"
    files = sorted(EXAMPLES_DIR.glob("*.json"))
    assert len(files) >= 3
    assert example_list() == [{"name": p.stem, "parts": len(json.loads(p.read_text())["parts"])}
                              for p in files]
    for p in files:
        assert example(p.stem) == assembly_to_json(load_assembly(p))  # as /import answers
    doc = example(files[0].stem)
    doc["parts"].clear()  # the caller's copy
    assert example(files[0].stem)["parts"]


@pytest.mark.parametrize("name", ["nope", "../grid", "grid.json", "", "GRID", "x" * 5000])
def test_only_a_shipped_name_is_an_example(name):
    with pytest.raises(UnknownExample) as info:
        example(name)
    line = str(info.value)
    assert isinstance(info.value, InputError) and "\n" not in line and len(line) < 300
    assert line.startswith("no example ") and "hexagon" in line
