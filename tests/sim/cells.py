"""Named small assemblies under gravity (0, -1) for the statics and settling tests, and the cases
both checkers must agree on: ``(name, assembly, ids, base, gravity, friction, stable)``."""

from __future__ import annotations

from pathlib import Path

from rap.io import load_assembly, parse_assembly

__all__ = ["CELLS", "STACK", "ARCH", "CENTRING", "WALL", "SLOPE", "CANTILEVER", "OVERHANG",
           "WEDGED", "AFRAME", "AGREEMENT", "DOWN", "wall_bricks"]

CELLS = Path(__file__).resolve().parents[2] / "assemblies" / "cells"
DOWN = (0, -1)

STACK = load_assembly(CELLS / "stack.json")
ARCH = load_assembly(CELLS / "arch.json")
CENTRING = load_assembly(CELLS / "arch-centring.json")
WALL = load_assembly(CELLS / "brick-wall-22.json")


def _make(name: str, parts: dict) -> object:
    return parse_assembly({"name": name, "parts": [{"id": k, "polygon": v}
                                                   for k, v in parts.items()]})


# a 16 x 16 square block on a slope of rise 1 in run 2 (tan 0.5): slides for friction < 0.5
SLOPE = _make("slope", {"wedge": [[0, 0], [40, 0], [40, 20]],
                        "block": [[12, 6], [20, 10], [16, 18], [8, 14]]})
# two 40 x 5 bars on a 100 x 10 plate: "short" overhangs its left end by 10 (centroid over the
# plate), "long" its right end by 24 (centroid 4 beyond the plate's corner: it tips)
CANTILEVER = _make("cantilever", {"plate": [[0, 0], [100, 0], [100, 10], [0, 10]],
                                  "short": [[-10, 10], [30, 10], [30, 15], [-10, 15]],
                                  "long": [[84, 10], [124, 10], [124, 15], [84, 15]]})
# a second block on top of the first, shifted right by 12 of its 20: its centroid overhangs
OVERHANG = _make("overhang", {"plate": [[0, 0], [40, 0], [40, 10], [0, 10]],
                              "low": [[10, 10], [30, 10], [30, 20], [10, 20]],
                              "high": [[22, 20], [42, 20], [42, 30], [22, 30]]})

# a 10 x 10 block between the two walls of a vertical slot, touching both, 10 above its floor:
# only pre-stress (the walls squeezing it) could hold it by friction
WEDGED = _make("wedged", {"base": [[0, 0], [30, 0], [30, 30], [20, 30], [20, 10], [10, 10],
                                   [10, 30], [0, 30]],
                          "block": [[10, 20], [20, 20], [20, 30], [10, 30]]})
# two slabs leaning on each other (touching along x = 50, 40 <= y <= 50) on a ground plate:
# neither moves alone (each would push into the other), together they splay unless the friction
# on the ground holds their thrust (between 0.3 and 0.4); only the program sees it
AFRAME = _make("a-frame", {"ground": [[0, 0], [100, 0], [100, 10], [0, 10]],
                           "left": [[10, 10], [20, 10], [50, 40], [50, 50]],
                           "right": [[80, 10], [90, 10], [50, 50], [50, 40]]})


def wall_bricks() -> list[str]:
    """The wall's bricks bottom-up, course by course, left to right."""
    return sorted((p for p in WALL.ids if p != "plate"),
                  key=lambda b: (int(b[1:].split("_")[0]), int(b.split("_b")[1])))


AGREEMENT = [
    ("stack", STACK, STACK.ids, "plate", DOWN, 0.5, True),
    ("stack sideways", STACK, STACK.ids, "plate", (1, 0), 0.5, False),
    ("stack tilted 26.6 deg", STACK, STACK.ids, "plate", (1, -2), 0.6, True),
    ("stack tilted 45 deg", STACK, STACK.ids, "plate", (1, -1), 0.5, False),
    ("stack, block2 missing", STACK, ["plate", "block1", "block3"], "plate", DOWN, 0.5, False),
    ("slope, friction 0.2", SLOPE, SLOPE.ids, "wedge", DOWN, 0.2, False),
    ("slope, friction 1.0", SLOPE, SLOPE.ids, "wedge", DOWN, 1.0, True),
    ("cantilever short", CANTILEVER, ["plate", "short"], "plate", DOWN, 0.5, True),
    ("cantilever long", CANTILEVER, ["plate", "long"], "plate", DOWN, 0.5, False),
    ("overhang", OVERHANG, OVERHANG.ids, "plate", DOWN, 0.5, False),
    ("arch", ARCH, ARCH.ids, "ground", DOWN, 0.5, True),
    ("arch, left voussoir", ARCH, ["ground", "left"], "ground", DOWN, 0.5, False),
    ("arch, right voussoir", ARCH, ["ground", "right"], "ground", DOWN, 0.5, False),
    ("arch, no keystone", ARCH, ["ground", "left", "right"], "ground", DOWN, 0.5, False),
    ("centring, left", CENTRING, ["centring", "left"], "centring", DOWN, 0.5, True),
    ("centring, left right", CENTRING, ["centring", "left", "right"], "centring", DOWN, 0.5, True),
    ("centring, arch", CENTRING, CENTRING.ids, "centring", DOWN, 0.5, True),
    ("wedged block", WEDGED, WEDGED.ids, "base", DOWN, 1.0, False),
    ("a-frame, friction 0.2", AFRAME, AFRAME.ids, "ground", DOWN, 0.2, False),
    ("a-frame, friction 0.6", AFRAME, AFRAME.ids, "ground", DOWN, 0.6, True),
    ("wall", WALL, WALL.ids, "plate", DOWN, 0.5, True),
    ("wall, brick held by a neighbour", WALL, ["plate", "c0_b0", "c1_b0", "c1_b1"], "plate", DOWN,
     0.5, False),
    ("wall upside down", WALL, WALL.ids, "plate", (0, 1), 0.5, False),
]
