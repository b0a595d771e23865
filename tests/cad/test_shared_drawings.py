"""The fifteen public drawings other people made (``../shared/drawings/``, read in place, never
copied here): each imports into the parts a person sees, with the defaults or with the one flag
its refusal names; the rest are refused for what they are. Expected counts are what the drawing
shows; areas are computed from the drawing's own numbers where it states them."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from rap.cad import DrawingError, ImportOptions, import_drawing

DRAWINGS = Path(__file__).resolve().parents[2].parent / "shared" / "drawings"
PX = 25.4 / 96  # mm per CSS px

pytestmark = pytest.mark.skipif(not DRAWINGS.is_dir(), reason=f"no {DRAWINGS}")

# a Penrose rhombus tiling with edge 2 user units (960 px over a 6.597-unit viewBox): 9 fat
# rhombi (angle 72 degrees) and 4 thin (36 degrees)
_UNIT = 960 / 6.597135955 * PX
PENROSE_AREA = (9 * 4 * math.sin(math.radians(72)) + 4 * 4 * math.sin(math.radians(36))) \
    * _UNIT ** 2

CASES = [  # file, options, parts, holes, total area (mm^2; None: not stated by the drawing)
    ("alinen-tangram.svg", {}, 7, 0, (132.28346 * PX) ** 2),
    ("alinen-tangram.svg", {"layers": ("PuzzleLayer",)}, 7, 0, (132.28346 * PX) ** 2),
    ("alinen-puzzle-cat.svg", {"tolerance": "0.05"}, 7, 0,
     (169.80684 - 33.529691) ** 2 * PX ** 2),  # its pieces: a square of T1's long side
    # hand-placed pieces overlapping by tenths of a millimetre: the flags their refusals name
    ("alinen-puzzle-square.svg", {"tolerance": "0.5"}, 7, 0,
     ((159.36499 - 23.087838) * PX) ** 2),  # a square of T1's long side
    ("alinen-tangram-mm-71f613e.svg", {"tolerance": "1"}, 7, 0,
     200.0 ** 2),  # the 200 mm square of its construction layer (locked: left out)
    ("alinen-tangram-mm-71f613e.svg", {"tolerance": "1", "layers": ("Puzzle",)}, 7, 0,
     200.0 ** 2),
    ("elm-logo.svg", {}, 7, 0, None),
    ("penrose-Rh_01.svg", {}, 13, 0, PENROSE_AREA),
    ("neon22-default-jigsaw.svg", {}, 20, 0, None),  # 5 x 4
    ("jigsawR-hexagonal_puzzle.svg", {}, 91, 0, None),  # 1 + 6 + 12 + 18 + 24 + 30
    ("kach-triangle3.svg", {"parts": "face"}, 49, 0, None),  # a 7-row triangle of pieces
    ("langmuir-ThreeInconsistentTriangles.dxf", {}, 3, 0, None),
    ("orrery-outer-ring-assem1.dxf", {}, 1, 5, None),  # a ring: inner circle and 4 slots
    ("orrery-small-gears.dxf", {}, 4, 17, None),  # 3 gears and the moon arm
    ("langmuir-Fogaskerek_Clock.dxf", {}, 1, 72, None),  # one plate, 72 cut-outs
]


@pytest.mark.parametrize("name, options, n, holes, area", CASES,
                         ids=[f"{c[0]}{'-' + '-'.join(c[1]) if c[1] else ''}" for c in CASES])
def test_a_drawing_imports_into_the_parts_a_person_sees(name, options, n, holes, area):
    result = import_drawing(DRAWINGS / name, ImportOptions(**options))
    parts = result.assembly.parts
    assert len(parts) == n, result.summary()
    assert sum(len(p.holes) for p in parts) == holes
    if area is not None:
        # hand-placed pieces leave hairline gaps: their sum is their union's area
        rel = 2e-2 if "tolerance" in options else 2e-3
        assert sum(float(p.area()) for p in parts) == pytest.approx(area, rel=rel)


def test_the_ring_is_the_annulus_less_its_slots():
    (ring,) = import_drawing(DRAWINGS / "orrery-outer-ring-assem1.dxf").assembly.parts
    slots = 4 * (102.2 - 99.35) * 6  # four 2.85 x 6 mm slots
    assert float(ring.area()) == pytest.approx(math.pi * (100 ** 2 - 80 ** 2) - slots, rel=1e-3)


def test_the_defaults_say_what_they_left_out_and_which_layers_made_parts():
    tangram = import_drawing(DRAWINGS / "alinen-tangram.svg").summary()
    assert "1 page bar on layer 'Timebar'" in tangram  # the game's timebar
    assert "1 shape drawn twice on layer 'Timebar'" in tangram  # its stroke, drawn again
    gears = import_drawing(DRAWINGS / "orrery-small-gears.dxf").summary()
    assert "left out: 2 centre lines, 1 DIMENSION, 1 POINT, 1 symbol" in gears


@pytest.mark.parametrize("name, what", [
    ("alinen-puzzle-cat.svg", "(--tolerance 0.05 absorbs the overlaps)"),  # the flag to use
    ("kach-triangle3.svg", "--parts face reads them as parts"),
    ("langmuir-Minimal-intersection-two-squares.dxf", "overlap by 100.00 mm^2, 5.00 mm deep"),
    ("alinen-puzzle-square.svg", "(--tolerance 0.5 absorbs the overlaps)"),
    ("alinen-tangram-mm-71f613e.svg", "(--tolerance 1 absorbs the overlaps)"),
])
def test_a_refusal_is_one_line_naming_the_flag_or_the_overlap(name, what):
    with pytest.raises(DrawingError) as e:
        import_drawing(DRAWINGS / name)
    assert what in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("name, options", [("neon22-default-jigsaw.svg", {}),
                                           ("kach-triangle3.svg", {"parts": "face"})])
def test_a_jigsaw_plans_to_a_confirmed_interlock_of_two_pieces(name, options):
    """Jigsaw pieces lock their neighbours in every direction: the plan is INFEASIBLE and names
    two touching pieces that no one-step translation separates (the 91-piece sheet does the same
    in seconds: ``python benchmarks/drawings.py --plan``)."""
    from rap.plan import plan
    from rap.plan.problem import PlanningProblem
    from rap.plan.report.result import PlanStatus
    from rap.sim.params import SimParams
    from tests.plan.standins import HashSim, TableCnn

    assembly = import_drawing(DRAWINGS / name, ImportOptions(**options)).assembly
    sim, cnn = HashSim(), TableCnn(lambda op: 0.5)
    result = plan(assembly, params=SimParams(trials=10), simulator=sim, model=cnn)
    assert result.status is PlanStatus.INFEASIBLE and len(result.interlocked) == 2
    problem = PlanningProblem(assembly, SimParams(trials=10))
    assert not problem.splits(frozenset(result.interlocked), False)
    assert sim.ops == 0
