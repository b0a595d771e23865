"""Named assemblies for the planning tests: the six of the paper and small ones written here."""

from __future__ import annotations

import json
from pathlib import Path

from rap.io import load_assembly, parse_assembly

ROOT = Path(__file__).resolve().parents[2]
ASSEMBLIES = ROOT / "assemblies"
SIX = ("grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "triangles")

#: a square plug filling the square hole of a frame: no translation separates them
FRAMED_HOLE = {"name": "framed-hole", "parts": [
    {"id": "frame", "polygon": [[0, 0], [30, 0], [30, 30], [0, 30]],
     "holes": [[[10, 10], [10, 20], [20, 20], [20, 10]]]},
    {"id": "plug", "polygon": [[10, 10], [20, 10], [20, 20], [10, 20]]},
    {"id": "side", "polygon": [[30, 0], [40, 0], [40, 30], [30, 30]]},
]}

#: three squares in a row
ROW3 = {"name": "row3", "parts": [
    {"id": "a", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
    {"id": "b", "polygon": [[10, 0], [20, 0], [20, 10], [10, 10]]},
    {"id": "c", "polygon": [[20, 0], [30, 0], [30, 10], [20, 10]]},
]}


def six(name: str):
    return load_assembly(ASSEMBLIES / f"{name}.json")


def memory(doc: dict):
    return parse_assembly(json.loads(json.dumps(doc)), source=doc["name"])


def write(doc: dict, path: Path) -> Path:
    path.write_text(json.dumps(doc))
    return path
