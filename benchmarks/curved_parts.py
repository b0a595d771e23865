"""Cold ``rap-farm plan`` on curved parts: a cut sheet of gears and an arm, as drawings give them.

The assemblies are built here, exactly (integer coordinates, in hundredths of a millimetre), like
the orrery's gear sheet of issue 44 (3 gears and an arm, 1,287 vertices, parts that never touch):

* ``apart``: three gears (24, 16 and 20 teeth, 300-420 vertices each, an axle hole each) and an
  arm (a slot with two holes) laid apart: every operation is free (``PlanningProblem.is_free``),
  so the plan is R = 1 with no simulation;
* ``mesh``: the same parts, the 16-tooth gear meshing with the 24-tooth one, its tooth tip lying
  flat on the other's root (an edge contact): the operations that separate them are simulated,
  with the simulator's simplified shapes (``rap.sim.outline``).

Each run is a fresh process (``python -m rap.cli plan``) with an empty score cache (a new
``--cache`` file): interpreter start-up, imports, loading, the NDBG, the scorer, the simulations and
the printing are all included (cold). Prints the wall time, R, the simulations and the machine's
load: the figures depend on what else runs.

    python benchmarks/curved_parts.py [DRAWING_OR_ASSEMBLY ...] [--write DIR] [--repeats 1]

With paths (a .json assembly, or a .dxf / .svg drawing the importer reads, e.g.
``../shared/drawings/orrery-small-gears.dxf``), those are planned instead of the built sheets.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.assembly import Assembly, assembly_to_json  # noqa: E402
from rap.io import parse_assembly  # noqa: E402

#: hundredths of a millimetre: the sheet's parts are 30-50 mm across
UNITS = "unit"


def _pt(cx: int, cy: int, r: float, angle: float) -> tuple[int, int]:
    return cx + round(r * math.cos(angle)), cy + round(r * math.sin(angle))


def gear_ring(cx: int, cy: int, teeth: int, pitch_radius: int, *, root_points: int = 6,
              tip_points: int = 6, flank_points: int = 2, phase: float = 0.0) -> list:
    """The outline of a gear (CCW integer points): ``teeth`` trapezoid teeth of module
    ``2 pitch_radius / teeth`` (addendum 1 module, dedendum 1.25), each tooth 40% of the pitch at
    the pitch circle, its tip and root sampled as arcs; tooth 0 centred at angle ``phase``. An even
    ``root_points`` and ``tip_points`` put two points of equal height either side of each gap's and
    tooth's middle (a flat, exactly)."""
    m = 2 * pitch_radius / teeth
    tip_r, root_r = pitch_radius + m, pitch_radius - 1.25 * m
    pitch = 2 * math.pi / teeth
    tip_half, root_half = 0.13 * pitch, 0.27 * pitch  # half-widths (radians) at tip and root
    out = []
    for k in range(teeth):
        c = phase + k * pitch
        gap = c - pitch / 2  # the gap before tooth k, then the tooth
        for i in range(root_points):
            a = gap - (pitch / 2 - root_half) + (pitch - 2 * root_half) * (i + 0.5) / root_points
            out.append(_pt(cx, cy, root_r, a))
        for i in range(1, flank_points + 1):
            t = i / (flank_points + 1)
            out.append(_pt(cx, cy, root_r + t * (tip_r - root_r),
                           c - root_half + t * (root_half - tip_half)))
        for i in range(tip_points):
            out.append(_pt(cx, cy, tip_r, c - tip_half + 2 * tip_half * (i + 0.5) / tip_points))
        for i in range(flank_points, 0, -1):
            t = i / (flank_points + 1)
            out.append(_pt(cx, cy, root_r + t * (tip_r - root_r),
                           c + root_half - t * (root_half - tip_half)))
    return out


def circle_ring(cx: int, cy: int, r: int, n: int, clockwise: bool = False) -> list:
    ring = [_pt(cx, cy, r, 2 * math.pi * i / n) for i in range(n)]
    return ring[::-1] if clockwise else ring


def slot_ring(x0: int, x1: int, y: int, r: int, n: int) -> list:
    """A slot (two half circles of radius ``r`` around (x0, y) and (x1, y)), ``n`` points each."""
    right = [_pt(x1, y, r, -math.pi / 2 + math.pi * i / (n - 1)) for i in range(n)]
    left = [_pt(x0, y, r, math.pi / 2 + math.pi * i / (n - 1)) for i in range(n)]
    return right + left


def _part(pid: str, outer: list, holes: list = ()) -> dict:
    return {"id": pid, "polygon": [list(p) for p in outer],
            "holes": [[list(p) for p in h] for h in holes]}


def gear_sheet(kind: str = "apart") -> Assembly:
    """The sheet (module doc), validated: ``kind`` ``apart`` or ``mesh``."""
    a = (0, 0)
    b = (7000, 0) if kind == "apart" else None
    parts = [_part("gear24", gear_ring(*a, 24, 2400, phase=math.pi / 2 + math.pi / 24),
                   [circle_ring(*a, 300, 32, clockwise=True)])]
    if b is None:  # mesh: the 16-tooth gear below, its top tooth's flat tip on the gap's flat root
        up = gear_ring(0, 0, 16, 1600, phase=math.pi / 2)
        top = max(y for _, y in up)
        low = min(y for x, y in parts[0]["polygon"] if abs(x) < 30)  # the flat under gear24
        b = (0, int(low) - top)
    parts.append(_part("gear16", gear_ring(*b, 16, 1600, phase=math.pi / 2),
                       [circle_ring(*b, 250, 32, clockwise=True)]))
    c = (-6000, -1000)
    parts.append(_part("gear20", gear_ring(*c, 20, 2000, root_points=7, tip_points=5),
                       [circle_ring(*c, 300, 32, clockwise=True)]))
    parts.append(_part("arm", slot_ring(3500, 8500, -6000, 600, 64),
                       [circle_ring(3500, -6000, 250, 24, clockwise=True),
                        circle_ring(8500, -6000, 250, 24, clockwise=True)]))
    return parse_assembly({"name": f"gear-sheet-{kind}", "units": UNITS, "parts": parts})


def cold_plan(path: Path) -> tuple[float, int, dict]:
    """(seconds, exit status, the plan document with ``stdout`` and ``stderr`` added) of
    ``python -m rap.cli plan PATH`` in a fresh process with an empty score cache; exits this
    script when the status is neither 0 nor 1 (benchmarks/drawings.py shares it)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "plan.json"
        cmd = [sys.executable, "-m", "rap.cli", "plan", str(path), "--cache",
               str(Path(tmp) / "scores.json"), "--out", str(out)]
        t = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
        wall = time.perf_counter() - t
        if p.returncode not in (0, 1):
            sys.exit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
        doc = json.loads(out.read_text()) if out.exists() else {}
        doc["stdout"], doc["stderr"] = p.stdout, p.stderr
        return wall, p.returncode, doc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="*", type=Path, help="assemblies or drawings to plan instead")
    ap.add_argument("--write", type=Path, help="write the built sheets into this directory")
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()
    print(f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        paths = list(args.paths)
        if not paths:
            where = args.write or Path(tmp)
            where.mkdir(parents=True, exist_ok=True)
            for kind in ("apart", "mesh"):
                asm = gear_sheet(kind)
                path = where / f"{asm.name}.json"
                path.write_text(json.dumps(assembly_to_json(asm)))
                paths.append(path)
        for path in paths:
            for _ in range(args.repeats):
                wall, _, doc = cold_plan(path)
                steps = doc.get("steps") or []
                sims = [ln for ln in doc["stdout"].splitlines() if "simulations run" in ln]
                print(f"{path.name}: cold plan {wall:.1f} s, R {doc.get('robustness')}, "
                      f"{sum(s['source'] == 'free' for s in steps)} of {len(steps)} steps free; "
                      f"{sims[0].split(';')[0] if sims else '?'}")


if __name__ == "__main__":
    main()
