"""Named tiny assemblies and operations for the simulator and renderer tests (integer coordinates).

Each case is ``(assembly, operation)``; directions are assembly directions (the moving
subassembly travels along them to its place). All operations here are feasible by construction.
"""

from __future__ import annotations

from fractions import Fraction

from rap.io import parse_assembly
from rap.operation import Operation, unit

__all__ = ["CASES", "case", "op", "TIGHT_PEG", "FUNNEL_PEG", "BESIDE", "MULTI", "CORNER",
           "ASSEMBLIES"]

# a 30 x 20 block with a 10 wide, 15 deep slot; the 10 x 20 peg fits exactly
_SLOT = [[0, 0], [30, 0], [30, 20], [20, 20], [20, 5], [10, 5], [10, 20], [0, 20]]
# the same block and peg, with a wide funnel: 10 wide up to y = 12, 26 wide at the top (y = 20)
_FUNNEL = [[0, 0], [30, 0], [30, 20], [28, 20], [20, 12], [20, 5], [10, 5], [10, 12], [2, 20],
           [0, 20]]
_PEG = [[10, 5], [20, 5], [20, 25], [10, 25]]

ASSEMBLIES = {
    "tight": parse_assembly({"name": "tight", "parts": [
        {"id": "slot", "polygon": _SLOT}, {"id": "peg", "polygon": _PEG}]}),
    "funnel": parse_assembly({"name": "funnel", "parts": [
        {"id": "slot", "polygon": _FUNNEL}, {"id": "peg", "polygon": _PEG}]}),
    "beside": parse_assembly({"name": "beside", "parts": [
        {"id": "block", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
        {"id": "box", "polygon": [[10, 0], [20, 0], [20, 10], [10, 10]]}]}),
    # peg + cap moving together into the funnel block
    "multi": parse_assembly({"name": "multi", "parts": [
        {"id": "slot", "polygon": _FUNNEL}, {"id": "peg", "polygon": _PEG},
        {"id": "cap", "polygon": [[4, 25], [26, 25], [26, 30], [4, 30]]}]}),
    # a square into the notch of an L, diagonally; the L has a hole
    "corner": parse_assembly({"name": "corner", "parts": [
        {"id": "ell", "polygon": [[0, 0], [20, 0], [20, 10], [10, 10], [10, 20], [0, 20]],
         "holes": [[[3, 3], [3, 6], [6, 6], [6, 3]]]},
        {"id": "sq", "polygon": [[10, 10], [20, 10], [20, 20], [10, 20]]}]}),
}


def op(moving, fixed, dx, dy) -> Operation:
    return Operation(frozenset(moving), frozenset(fixed), unit(dx, dy),
                     (Fraction(dx), Fraction(dy)))


TIGHT_PEG = (ASSEMBLIES["tight"], op({"peg"}, {"slot"}, 0, -1))
FUNNEL_PEG = (ASSEMBLIES["funnel"], op({"peg"}, {"slot"}, 0, -1))
BESIDE = (ASSEMBLIES["beside"], op({"box"}, {"block"}, -1, 0))
MULTI = (ASSEMBLIES["multi"], op({"peg", "cap"}, {"slot"}, 0, -1))
CORNER = (ASSEMBLIES["corner"], op({"sq"}, {"ell"}, -1, -1))

CASES = {
    "tight_peg": TIGHT_PEG,
    "funnel_peg": FUNNEL_PEG,
    "beside": BESIDE,
    "beside_down": (ASSEMBLIES["beside"], op({"box"}, {"block"}, 0, -1)),
    "multi": MULTI,
    "corner": CORNER,
    "corner_shallow": (ASSEMBLIES["corner"], op({"sq"}, {"ell"}, -1, -3)),
}


def case(name: str):
    return CASES[name]
