"""Benchmark of the simulator's scene building: its shapes made through Chipmunk's C calls
(``rap.sim.simulator.new_poly``) against ``pymunk.Poly`` objects, on the same pieces.

For each operation (every online partition of each assemblies/*.json, ``--limit`` per assembly,
and the curved 7-part DXF drawing of tests/serve/test_page.py when ezdxf is there): every
trial's moving and fixed pieces made and added to a fresh space as ``build_scene`` lays them out,
once as pymunk's shape objects (``pymunk.Poly`` + ``Space.add``, what the simulator did before)
and once as raw ``cpShape*`` (what it does now), then removed again trial by trial
(``remove_trial``'s work). Both ways make the same Chipmunk calls in the same order; the check
that they give the same scene bit for bit is in tests/sim (``test_raw_shapes_*``) and here
(the two spaces' shape counts and the bodies' masses). Prints per assembly the shapes made and
the seconds of each way, and on the last line ``speed-up of the shapes: X.XXx`` (pymunk's time
over the raw calls' time, over all).

    python benchmarks/scene_shapes.py [--trials 100] [--limit 6] [--repeat 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pymunk
from pymunk._chipmunk import lib as cp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.sim.outline import assembly_outlines  # noqa: E402
from rap.sim.params import DEFAULT_PARAMS  # noqa: E402
from rap.sim.kernel import new_poly  # noqa: E402


def pieces_of(assembly, operation, params):
    """(moving pieces, fixed pieces) of ``operation`` in assembly units."""
    pieces = assembly_outlines(assembly, params.shape_tolerance, params.shape_pieces)
    return ([pc for i in sorted(operation.moving) for pc in pieces[i]],
            [pc for i in sorted(operation.fixed) for pc in pieces[i]])


def with_pymunk(moving, fixed, trials: int, params) -> tuple[float, int, float]:
    t0 = time.perf_counter()
    space = pymunk.Space()
    made = []
    for k in range(trials):
        body = pymunk.Body()
        shapes = [pymunk.Poly(body, pc, radius=params.poly_radius) for pc in moving]
        for sh in shapes:
            cp.cpShapeSetDensity(sh._shape, params.density)
        space.add(body, *shapes)
        static = [pymunk.Poly(space.static_body, [(x + 1e3 * k, y) for x, y in pc],
                              radius=params.poly_radius) for pc in fixed]
        space.add(*static)
        made.append((body, shapes, static))
    mass = made[0][0].mass
    count = len(space.shapes)
    for body, shapes, static in made:
        space.remove(body, *shapes, *static)
    return time.perf_counter() - t0, count, mass


def with_raw_calls(moving, fixed, trials: int, params) -> tuple[float, int, float]:
    t0 = time.perf_counter()
    space = pymunk.Space()
    sp, ground = space._space, space.static_body._body
    made = []
    for k in range(trials):
        body = pymunk.Body()
        shapes = [new_poly(body._body, pc, params.poly_radius) for pc in moving]
        for c in shapes:
            cp.cpShapeSetDensity(c, params.density)
        space.add(body)
        static = [new_poly(ground, [(x + 1e3 * k, y) for x, y in pc], params.poly_radius)
                  for pc in fixed]
        for c in (*shapes, *static):
            cp.cpSpaceAddShape(sp, c)
        made.append((body, shapes, static))
    mass = made[0][0].mass
    count = sum(len(s) + len(f) for _, s, f in made)
    for body, shapes, static in made:
        space.remove(body)
        for c in (*shapes, *static):
            cp.cpSpaceRemoveShape(sp, c)
    return time.perf_counter() - t0, count, mass


def cases(limit: int):
    """(name, assembly, operations) per assembly: benchmarks/sim.py's online partitions of each
    assemblies/*.json (``limit`` each), then the curved drawing."""
    from benchmarks.sim import assembly_cases

    out: dict[str, tuple] = {}
    for label, a, op in assembly_cases(limit):
        out.setdefault(label.split(":")[0], (a, []))[1].append(op)
    grouped = [(name, a, ops) for name, (a, ops) in out.items()]
    try:
        grouped.append(curved_drawing(limit))
    except ImportError:
        print("(ezdxf is not installed: the curved drawing is left out)")
    return grouped


def curved_drawing(limit: int):
    import tempfile

    from rap.cad import import_drawing
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.partitions import online_partitions

    from tests.serve.test_page import seven_part_dxf

    with tempfile.TemporaryDirectory() as tmp:
        a = import_drawing(seven_part_dxf(Path(tmp) / "pegs.dxf")).assembly
    ops = [p.operation() for p in online_partitions(build_ndbg(a), frozenset(a.ids))]
    return "pegs.dxf (curved)", a, ops[:limit]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=DEFAULT_PARAMS.trials)
    ap.add_argument("--limit", type=int, default=6, help="operations per assembly")
    ap.add_argument("--repeat", type=int, default=3, help="the best of this many runs each way")
    args = ap.parse_args()
    params = DEFAULT_PARAMS
    total_py = total_raw = 0.0
    print(f"{'assembly':<22} {'shapes':>8} {'pymunk s':>9} {'raw s':>8} {'ratio':>6}")
    for name, assembly, ops in cases(args.limit):
        t_py = t_raw = 0.0
        shapes = 0
        for op in ops:
            moving, fixed = pieces_of(assembly, op, params)
            runs_py = [with_pymunk(moving, fixed, args.trials, params) for _ in range(args.repeat)]
            runs_raw = [with_raw_calls(moving, fixed, args.trials, params)
                        for _ in range(args.repeat)]
            if runs_py[0][1:] != runs_raw[0][1:]:
                raise SystemExit(f"{name}: the two ways made different spaces "
                                 f"({runs_py[0][1:]} against {runs_raw[0][1:]})")
            t_py += min(r[0] for r in runs_py)
            t_raw += min(r[0] for r in runs_raw)
            shapes += runs_raw[0][1]
        total_py, total_raw = total_py + t_py, total_raw + t_raw
        print(f"{name:<22} {shapes:>8} {t_py:>9.3f} {t_raw:>8.3f} {t_py / t_raw:>5.2f}x")
    print(f"speed-up of the shapes: {total_py / total_raw:.2f}x")


if __name__ == "__main__":
    main()
