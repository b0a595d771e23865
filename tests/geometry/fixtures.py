"""Named tiny assemblies for the geometry tests (in the manner of shapely/tests/common.py)."""

from __future__ import annotations

from rap.assembly import Assembly
from rap.io import parse_assembly


def square(x, y, s=1):
    return [[x, y], [x + s, y], [x + s, y + s], [x, y + s]]


def make(name: str, parts: list[dict]) -> Assembly:
    return parse_assembly({"name": name, "parts": parts}, source=f"<{name}>")


def grid_dict(k: int) -> list[dict]:
    return [{"id": f"r{r}c{c}", "polygon": square(c, r)} for r in range(k) for c in range(k)]


SINGLE = make("single", [{"id": "a", "polygon": square(0, 0)}])
TWO_SIDE_BY_SIDE = make("two", [{"id": "a", "polygon": square(0, 0)},
                                {"id": "b", "polygon": square(1, 0)}])
CORNER_TOUCH = make("corner", [{"id": "a", "polygon": square(0, 0)},
                               {"id": "b", "polygon": square(1, 1)}])
FAR_APART = make("far", [{"id": "a", "polygon": square(0, 0)},
                         {"id": "b", "polygon": square(10, 0)}])
GRID2 = make("grid2", grid_dict(2))
GRID3 = make("grid3", grid_dict(3))
# a block with a dovetail tenon locked in a block with the matching mortise
DOVETAIL = make("dovetail", [
    {"id": "mortise", "polygon": [[0, 0], [10, 0], [10, 4], [6, 4], [7, 1], [3, 1], [4, 4], [0, 4]]},
    {"id": "tenon", "polygon": [[3, 1], [7, 1], [6, 4], [10, 4], [10, 6], [0, 6], [0, 4], [4, 4]]},
])
# a square held in the hole of a frame, touching it all around
FRAMED = make("framed", [
    {"id": "frame", "polygon": square(0, 0, 10), "holes": [square(3, 3, 4)]},
    {"id": "core", "polygon": square(3, 3, 4)},
])
# a frame with a loose square inside its hole, and a separate square outside
FRAMED_LOOSE = make("framed-loose", [
    {"id": "frame", "polygon": square(0, 0, 10), "holes": [square(3, 3, 4)]},
    {"id": "core", "polygon": square(4, 4, 2)},
    {"id": "out", "polygon": square(10, 0, 2)},
])
# an L-shaped part (non-convex) hugging a square in its corner
L_AND_SQUARE = make("l-square", [
    {"id": "L", "polygon": [[0, 0], [3, 0], [3, 1], [1, 1], [1, 3], [0, 3]]},
    {"id": "s", "polygon": square(1, 1)},
])
def decimals() -> Assembly:
    """Three parts with boundaries at 0.1 and 0.3 parsed from JSON text (exact decimals)."""
    import json
    from decimal import Decimal

    text = """{"name": "decimals", "parts": [
        {"id": "a", "polygon": [[0, 0], [0.1, 0], [0.1, 1], [0, 1]]},
        {"id": "b", "polygon": [[0.1, 0], [0.3, 0], [0.3, 1], [0.1, 1]]},
        {"id": "c", "polygon": [[0.3, 0], [0.6, 0], [0.6, 1], [0.3, 1]]}]}"""
    return parse_assembly(json.loads(text, parse_float=Decimal), source="<decimals>")


DECIMALS = decimals()

VALID = [SINGLE, TWO_SIDE_BY_SIDE, CORNER_TOUCH, FAR_APART, GRID2, GRID3, DOVETAIL, FRAMED,
         FRAMED_LOOSE, L_AND_SQUARE, DECIMALS]
