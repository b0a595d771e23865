"""Assembly files in, validated assemblies out: exact parsing plus exact geometric validation.

``load_assembly(path)`` / ``parse_assembly(data)`` = ``rap.assembly_reader`` (exact JSON parsing
and structural checks) + ``rap.geometry.validation`` (simple rings, holes inside, interiors
disjoint). This module sits above both, so that the data layer never imports the geometry layer.
Every problem raises ``rap.assembly.AssemblyError``: one line naming the file, the part and the
problem. Cost, within ``rap.assembly.LIMITS``: reading is linear in the file's size; validation is
O(sum of q^2) exact-filtered segment pairs for the rings (q vertices per ring) plus the overlap
test of parts whose boxes meet, O(n^2 q^2) in the worst case (n parts; a star ring, whose edges'
boxes meet, is the worst case for one ring). Timings: ``python benchmarks/validation.py``,
docs/RESULTS.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rap.assembly import LIMITS, Assembly, InputLimits, assembly_to_json
from rap.assembly_reader import assembly_from_json, read_assembly_json
from rap.cad.importer import DRAWING_SUFFIXES  # ezdxf and svgelements load when a drawing does
from rap.geometry.validation import validate_assembly

__all__ = ["load_assembly", "parse_assembly", "assembly_to_json"]


def parse_assembly(data: Any, source: str = "<memory>", default_name: str = "assembly",
                   validate: bool = True, limits: InputLimits = LIMITS) -> Assembly:
    """An ``Assembly`` from decoded JSON (numbers as ``int``/``Decimal``), within ``limits``,
    validated exactly."""
    assembly = assembly_from_json(data, source, default_name, limits)
    if validate:
        validate_assembly(assembly)
    return assembly


def load_assembly(path: str | Path, validate: bool = True) -> Assembly:
    """Read an assembly JSON file exactly and validate it. Raises ``AssemblyError`` (one line).

    A drawing (``.dxf``, ``.svg``) is imported instead, with ``rap.cad``'s default options
    (millimetres, tolerance 0.01, a part per closed loop), and always validated: this is how every
    command that takes an assembly takes a drawing."""
    if Path(path).suffix.lower() in DRAWING_SUFFIXES:
        from rap.cad.importer import import_drawing

        return import_drawing(path).assembly
    assembly = read_assembly_json(path)
    if validate:
        validate_assembly(assembly)
    return assembly
