"""The execution tests' cases: a peg in a slot of a given gap, and a prefix of the 22-brick wall's
plan (six steps of scores 0.88-0.95: a sequence success near one half)."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

from rap.assembly import Assembly, Part
from rap.operation import Operation

ROOT = Path(__file__).resolve().parents[2]
WALL = ROOT / "assemblies" / "cells" / "brick-wall-22.json"
WALL_PLAN = ROOT / "tests" / "robot" / "data" / "brick-wall-22.plan.json"


def slot(gap) -> tuple[Assembly, Operation]:
    """A 10-wide slot 8 deep in a base, and a peg ``gap`` narrower on each side, inserted down."""
    g = Fraction(gap)
    base = Part("base", ((0, 0), (30, 0), (30, 10), (20, 10), (20, 2), (10, 2), (10, 10), (0, 10)))
    peg = Part("peg", ((10 + g, 2), (20 - g, 2), (20 - g, 15), (10 + g, 15)))
    return Assembly("slot", (base, peg)), Operation(frozenset({"peg"}), frozenset({"base"}),
                                                    (0.0, -1.0))


def wall_prefix(steps: int = 6):
    """(assembly, the first ``steps`` operations of the wall's plan)."""
    from rap.robot.inputs import load_plan_and_assembly

    plan, _, asm = load_plan_and_assembly(WALL_PLAN, WALL)
    return asm, tuple(s.to_operation() for s in plan.steps[:steps])
