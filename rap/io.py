"""Assembly files in, validated assemblies out: exact parsing plus exact geometric validation.

``load_assembly(path)`` / ``parse_assembly(data)`` = ``rap.assembly`` (exact JSON parsing and
structural checks) + ``rap.geometry.validation`` (simple rings, holes inside, interiors disjoint).
This module sits above both, so that the data layer never imports the geometry layer. Every
problem raises ``rap.assembly.AssemblyError``: one line naming the file, the part and the problem.
Cost: O(n^2 q^2) worst case for the validation (n parts, q vertices per part).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rap.assembly import Assembly, assembly_from_json, assembly_to_json, read_assembly_json
from rap.geometry.validation import validate_assembly

__all__ = ["load_assembly", "parse_assembly", "assembly_to_json"]


def parse_assembly(data: Any, source: str = "<memory>", default_name: str = "assembly",
                   validate: bool = True) -> Assembly:
    """An ``Assembly`` from decoded JSON (numbers as ``int``/``Decimal``), validated exactly."""
    assembly = assembly_from_json(data, source, default_name)
    if validate:
        validate_assembly(assembly)
    return assembly


def load_assembly(path: str | Path, validate: bool = True) -> Assembly:
    """Read an assembly JSON file exactly and validate it. Raises ``AssemblyError`` (one line)."""
    assembly = read_assembly_json(path)
    if validate:
        validate_assembly(assembly)
    return assembly
