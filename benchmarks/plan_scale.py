"""Planning at scale: the default planner, simulator-only greedy and the optimum, 7 to 100 parts.

    python benchmarks/plan_scale.py [--kinds herringbone,wall,grid,convex,polyomino,packing]
        [--sizes 18,22,25,30,36,44,49,60,100] [--seed 11] [--assembly-seed 0]
        [--assemblies herringbone:18,wall:22,...] [--optimum-max-parts 12]
        [--optimum-max-operations 3000] [--workers 1] [--json rows.json] [--quick]

Builds seeded assemblies of several kinds (``assemblies_for``; a rerun builds the same ones) and
plans each in this process through the front door, ``rap.plan.plan`` (what ``rap-farm plan A.json
--no-cache --seed 11`` runs), with the same seed for every method, a fresh score cache each, the
shipped model loaded once and the simulations in this process (``--workers``: more processes, as
the CLI uses every CPU): the default (``search``), simulator-only greedy (``sim``) and, where the
budget allows it (at most ``--optimum-max-parts`` parts and ``--optimum-max-operations`` operations
in the AND/OR graph), the optimum (``optimal``, which simulates every operation). The default and
greedy of one assembly run back to back, so their ratios are measured under the same load.

Kinds (``KINDS``; every assembly has exact integer coordinates and is verified: valid, and not
interlocked):

* ``herringbone``: 2 x 1 bricks (20 x 10) in a herringbone, grown brick by brick from a seeded
  centre (a compact, connected patch of exactly n bricks);
* ``wall``: a running-bond brick wall, the ``wall`` family with 20 x 10 bricks touching (gap 0),
  courses and bricks per course chosen to give exactly n parts (rows x bricks + rows // 2);
* ``grid``: an r x c grid of 10 x 10 squares (``rap.geometry.families.simple.grid`` when n is a
  square);
* ``convex``: the ``convex`` family (jittered lattice), quads where r x c = n, else hexagons or
  triangles;
* ``tiling``: ``rap.geometry.families.simple.random_tiling`` (jittered convex quads);
* ``polyomino``: a rectangle tiled by random non-convex polyominoes (the ``polyomino`` family,
  at most 40 parts, its largest);
* ``knobs``: jigsaw cells with knobs (the ``knobs`` family, at most 64 parts, its largest);
* ``packing``: rectangles and L-shapes in an open tray (the ``packing`` family, at most 40 parts,
  its largest).

Without ``--sizes`` each kind runs its own list (``DEFAULT_SIZES``: the issue's table, 7 to 100
parts); with it, every kind runs every size it can build (the others are named and skipped).

Per assembly it prints, for each method: planning time (``PlanResult.seconds``) and wall time (the
``plan`` call: search, the simulator's evaluation of the returned sequence, the bound), R (the
product of the simulated step scores), expected failed steps (the sum of 1 - r over the steps),
the bound (``bound["robustness_upper"]``) and its scope, and the share of the graph's operations
the CNN scored (``stats["predicted_operations"] / stats["operations"]``; n/a where the search does
not know the graph, e.g. beam); then the default's ratios to greedy in time and R. Summary lines
follow per band of the issue's targets: 18-25 parts (time and R ratios), 30-100 parts (on how many
assemblies the default's R >= greedy's, the geometric mean of R ratios, time ratios) and up to 12
parts (the default's R and time over the optimum's). The CPU count and load average are printed:
times depend on what else runs, ratios less so. No timing is asserted anywhere.

``--quick``: a smoke run (``QUICK``: three kinds at 6 and 7 parts, 10 trials a score).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from rap.assembly import Assembly, Part  # noqa: E402

__all__ = ["KINDS", "DEFAULT_SIZES", "QUICK", "build", "assemblies_for", "herringbone", "grid",
           "wall_shape", "convex_shape", "main"]

BRICK = 10  # a herringbone or grid unit: bricks are 2 BRICK x BRICK, squares BRICK x BRICK


def _rng(kind: str, n: int, seed: int) -> np.random.Generator:
    tag = sum(ord(ch) << (8 * (i % 4)) for i, ch in enumerate(kind))
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(n), tag]))


def _rect(pid: str, x0: int, y0: int, x1: int, y1: int) -> Part:
    return Part(pid, tuple((Fraction(x), Fraction(y))
                           for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))))


def _checked(asm: Assembly, n: int) -> Assembly:
    from rap.geometry.families import verify

    if len(asm) != n:
        raise AssertionError(f"{asm.name}: built {len(asm)} parts, asked for {n}")
    verify(asm)  # integer vertices, valid, and a full decomposition exists
    return asm


# -- herringbone ---------------------------------------------------------------------------------
def _touch(a: tuple, b: tuple) -> bool:
    """Two axis-aligned rectangles (x0, y0, x1, y1) share an edge segment of positive length."""
    if a[2] == b[0] or b[2] == a[0]:
        return min(a[3], b[3]) > max(a[1], b[1])
    if a[3] == b[1] or b[3] == a[1]:
        return min(a[2], b[2]) > max(a[0], b[0])
    return False


def herringbone(n: int, seed: int = 0) -> Assembly:
    """n bricks of a 90-degree herringbone of 2 x 1 bricks (scaled by ``BRICK``): horizontal
    bricks at (0, 0) + i (1, 1) + j (2, -2), vertical ones at (2, -1) + i (1, 1) + j (2, -2) (a
    tiling of the plane), grown from the brick nearest a seeded centre by adding, each time, the
    touching brick nearest the centre (ties broken by a seeded draw): a connected patch."""
    if n < 1:
        raise ValueError("n must be positive")
    rng = _rng("herringbone", n, seed)
    k = math.isqrt(n) + 4
    rects = []
    for i in range(-2 * k, 2 * k + 1):
        for j in range(-k, k + 1):
            x, y = i + 2 * j, i - 2 * j
            rects.append(("h", (x, y, x + 2, y + 1)))
            rects.append(("v", (x + 2, y - 1, x + 3, y + 1)))
    cx, cy = rng.uniform(0.0, 2.0, size=2)
    tie = rng.permutation(len(rects))

    def key(i):
        x0, y0, x1, y1 = rects[i][1]
        return ((x0 + x1) / 2 - cx) ** 2 + ((y0 + y1) / 2 - cy) ** 2, int(tie[i])

    chosen = [min(range(len(rects)), key=key)]
    frontier = set()
    while len(chosen) < n:
        last = rects[chosen[-1]][1]
        frontier |= {i for i, (_, r) in enumerate(rects) if _touch(last, r)}
        frontier -= set(chosen)
        chosen.append(min(frontier, key=key))
    xs = [rects[i][1] for i in chosen]
    x_min, y_min = min(r[0] for r in xs), min(r[1] for r in xs)
    parts = sorted(((y0 - y_min, x0 - x_min, kind, (x0, y0, x1, y1))
                    for kind, (x0, y0, x1, y1) in (rects[i] for i in chosen)))
    return Assembly(f"herringbone-{n}-s{seed}", tuple(
        _rect(f"{kind}{m}", (x0 - x_min) * BRICK, (y0 - y_min) * BRICK, (x1 - x_min) * BRICK,
              (y1 - y_min) * BRICK) for m, (_, _, kind, (x0, y0, x1, y1)) in enumerate(parts)))


# -- grids, walls, convex tilings ------------------------------------------------------------------
def _near_square(n: int) -> tuple[int, int]:
    r = max(d for d in range(1, math.isqrt(n) + 1) if n % d == 0)
    return r, n // r


def grid(n: int, seed: int = 0) -> Assembly:
    """An r x c grid of ``BRICK`` squares, r the largest divisor of n not above its square root
    (``simple.grid`` when r = c)."""
    from rap.geometry.families.simple import grid as square_grid

    rows, cols = _near_square(n)
    if rows == cols:
        return square_grid(rows, BRICK, name=f"grid-{n}")
    return Assembly(f"grid-{n}", tuple(
        _rect(f"r{r}c{c}", c * BRICK, r * BRICK, (c + 1) * BRICK, (r + 1) * BRICK)
        for r in range(rows) for c in range(cols)))


def wall_shape(n: int) -> tuple[int, int] | None:
    """(courses, bricks) of a ``wall`` with exactly n parts, the most even one (None: none)."""
    fits = [(r, b) for r in range(1, 21) for b in range(1, 21) if r * b + r // 2 == n]
    return min(fits, key=lambda rb: (abs(rb[0] - rb[1]), rb[0])) if fits else None


def convex_shape(n: int) -> dict | None:
    """``convex`` options with exactly n cells: quads when an r x c of aspect at most 2 fits,
    else the most even of quads, hexagons and triangles (None: none)."""
    count = {"quad": lambda r, c: r * c, "hex": lambda r, c: r * c + r // 2,
             "tri": lambda r, c: 2 * r * c}
    fits = [(cell, r, c) for cell in count for r in range(1, 13) for c in range(1, 13)
            if count[cell](r, c) == n]
    if not fits:
        return None
    cell, r, c = min(fits, key=lambda f: (f[0] != "quad" or max(f[1], f[2]) > 2 * min(f[1], f[2]),
                                          abs(math.log(f[1] / f[2])), f[0]))
    return {"rows": r, "cols": c, "cell": cell}


def _family(family: str, seed: int, **options) -> Assembly:
    from rap.geometry.families import generate

    return generate(family, seed, **options)


def _wall(n, seed):
    rb = wall_shape(n)
    if rb is None:
        raise ValueError(f"no running-bond wall of the family has {n} parts")
    return _family("wall", seed, rows=rb[0], bricks=rb[1], half=BRICK, height=BRICK, gap=0)


def _convex(n, seed):
    shape = convex_shape(n)
    if shape is None:
        raise ValueError(f"no convex tiling of the family has {n} cells")
    return _family("convex", seed, **shape)


def _tiling(n, seed):
    from rap.geometry.families.simple import random_tiling

    return random_tiling(n, _rng("tiling", n, seed), name=f"tiling-{n}-s{seed}")


def _polyomino(n, seed):
    if not 2 <= n <= 40:
        raise ValueError("the polyomino family has 2 to 40 pieces")
    cells = 3 * n  # about three cells a piece, in a near-square rectangle of at most 16 x 16
    cols = min(16, max(2, math.ceil(math.sqrt(cells * 1.25))))
    rows = min(16, max(2, math.ceil(cells / cols)))
    return _family("polyomino", seed, cols=cols, rows=rows, pieces=n, cell=12)


def _knobs(n, seed):
    fits = [(r, c) for r in range(1, 9) for c in range(1, 9) if r * c == n]
    if not fits:
        raise ValueError("the knobs family has r x c cells, r and c at most 8")
    r, c = min(fits, key=lambda rc: (abs(rc[0] - rc[1]), rc[0]))
    return _family("knobs", seed, rows=r, cols=c)


def _packing(n, seed):
    if not 2 <= n <= 40:
        raise ValueError("the packing family has 2 to 40 parts")
    return _family("packing", seed, parts=n)


#: kind -> builder(n, seed) of an assembly of exactly n parts (ValueError: not that size)
KINDS = {"herringbone": herringbone, "wall": _wall, "grid": grid, "convex": _convex,
         "tiling": _tiling, "polyomino": _polyomino, "knobs": _knobs, "packing": _packing}
#: each kind's sizes without ``--sizes``: the issue's table (herringbone 18 and 36, wall 22 and
#: 44, grids 25, 49, 100, convex 30 and 60) and more, with the families at their largest
DEFAULT_SIZES = {"herringbone": (7, 18, 36, 60), "wall": (12, 22, 44, 100),
                 "grid": (9, 25, 49, 100), "convex": (12, 30, 60), "polyomino": (10, 20, 40),
                 "packing": (8, 24, 40)}
#: the ``--quick`` smoke run
QUICK = {"herringbone": (6,), "wall": (7,), "grid": (6,)}


def build(kind: str, n: int, seed: int = 0) -> Assembly:
    """The verified assembly of ``kind`` with exactly ``n`` parts for ``seed`` (deterministic);
    ``ValueError`` when the kind has no assembly of that size."""
    return _checked(KINDS[kind](n, seed), n)


def assemblies_for(kinds, sizes=None, seed: int = 0):
    """``[(kind, n, assembly or the reason it is skipped)]``: each kind at ``sizes`` (None: its
    ``DEFAULT_SIZES``)."""
    out = []
    for kind in kinds:
        for n in (sizes if sizes is not None else DEFAULT_SIZES.get(kind, ())):
            try:
                out.append((kind, n, build(kind, n, seed)))
            except ValueError as exc:
                out.append((kind, n, str(exc)))
    return out


# -- planning ----------------------------------------------------------------------------------
def _run(asm, method, model, seed, params, workers: int = 1) -> dict:
    from rap.plan import plan
    from rap.plan.scoring.local_simulator import LocalSimulator

    t = time.perf_counter()
    if workers > 1:  # as ``rap-farm plan`` does (every CPU); the front door's own: in-process
        sim = LocalSimulator(processes=workers)
        try:
            r = plan(asm, method, model=model, seed=seed, params=params, simulator=sim)
        finally:
            sim.close()
    else:
        r = plan(asm, method, model=model, seed=seed, params=params)
    wall = time.perf_counter() - t
    scores = [s.score for s in r.steps]
    stats = r.stats
    share = None
    if (stats.get("operations") and "predicted_operations" in stats
            and stats.get("search") != "beam"):
        share = stats["predicted_operations"] / stats["operations"]
    bound = r.bound or {}
    return {"status": r.status.value, "seconds": r.seconds, "wall_s": wall,
            "robustness": r.robustness,
            "expected_failures": (sum(1.0 - s for s in scores)
                                  if scores and None not in scores else None),
            "weakest": min(scores) if scores and None not in scores else None,
            "bound": bound.get("robustness_upper"), "scope": bound.get("scope"),
            "search": stats.get("search"), "operations": stats.get("operations"),
            "predicted_operations": stats.get("predicted_operations"), "scored_share": share,
            "message": r.message if not r.found else "",
            "stats": {k: v for k, v in stats.items() if isinstance(v, (int, float, str))}}


def _ratio(a, b):
    if a is None or b is None:
        return None
    if b <= 0:
        return math.inf if a > 0 else 1.0
    return a / b


def _graph_operations(asm, seed, params, limit: int) -> int | None:
    """The AND/OR graph's operations, or None past ``limit``."""
    from rap.plan.graph import TooLarge, reachable
    from rap.plan.problem import PlanningProblem

    try:
        return sum(len(c) for c in reachable(PlanningProblem(asm, params, seed), limit).values())
    except TooLarge:
        return None


def _g(x, spec=".3g"):
    return "-" if x is None else format(x, spec)


def _gmean(xs):
    xs = [x for x in xs if x is not None and 0 < x < math.inf]
    return math.exp(statistics.fmean(math.log(x) for x in xs)) if xs else None


def _band(rows, lo, hi):
    return [r for r in rows if lo <= r["parts"] <= hi and r["time_ratio"] is not None
            and r["r_ratio"] is not None]


def _ratios(band) -> tuple[str, str]:
    """A band's time and R ratios to greedy, as printed: ``(time, R)``."""
    ts = [r["time_ratio"] for r in band]
    rs = [r["r_ratio"] for r in band]
    return (f"time default/greedy {min(ts):.2f} to {max(ts):.2f} (geometric mean "
            f"{_gmean(ts):.2f})",
            f"R default/greedy geometric mean {_g(_gmean(rs))} ({min(rs):.3g} to {max(rs):.3g})")


def summary(rows) -> list[str]:
    """The lines per target band (module doc)."""
    out = []
    small = [r for r in rows if r["parts"] <= 12 and r.get("optimal")
             and r["optimal"]["robustness"]]
    if small:
        rs = [r["default"]["robustness"] / r["optimal"]["robustness"] for r in small]
        ts = [r["default"]["seconds"] / max(r["optimal"]["seconds"], 1e-9) for r in small]
        out.append(f"up to 12 parts ({len(small)} with the optimum): default R / optimum R "
                   f"min {min(rs):.3f}, mean {statistics.fmean(rs):.3f}; default time / optimum "
                   f"time max {max(ts):.2f}, geometric mean {_gmean(ts):.2f}")
    mid = _band(rows, 18, 25)
    if mid:
        times, rs = _ratios(mid)
        out.append(f"18-25 parts ({len(mid)}): {times}; {rs}")
    big = _band(rows, 30, 100)
    if big:
        times, rs = _ratios(big)
        ok = sum((r["default"]["robustness"] or 0.0) >= (r["sim"]["robustness"] or 0.0)
                 for r in big)
        out.append(f"30-100 parts ({len(big)}): default R >= greedy R on {ok} of {len(big)}; "
                   f"{rs}; {times}")
    return out


HEADER = (f"{'assembly':<28} {'n':>3} | {'default: plan s':>15} {'wall s':>6} {'R':>8} "
          f"{'E[fail]':>7} {'bound':>8} {'scope':>5} {'scored':>6} | {'greedy: plan s':>14} "
          f"{'wall s':>6} {'R':>8} {'E[fail]':>7} | {'optimum R':>9} {'plan s':>6} | "
          f"{'t ratio':>7} {'R ratio':>7}")


def line(row) -> str:
    d, g, o = row["default"], row["sim"], row.get("optimal")
    share = ("n/a" if d["scored_share"] is None else f"{d['scored_share']:.0%}")
    return (f"{row['name'][:28]:<28} {row['parts']:>3} | {d['seconds']:>15.2f} {d['wall_s']:>6.1f} "
            f"{_g(d['robustness']):>8} {_g(d['expected_failures'], '.2f'):>7} "
            f"{_g(d['bound']):>8} {(d['scope'] or '-'):>5} {share:>6} | {g['seconds']:>14.2f} "
            f"{g['wall_s']:>6.1f} {_g(g['robustness']):>8} {_g(g['expected_failures'], '.2f'):>7} "
            f"| {_g(o and o['robustness']):>9} {_g(o and o['seconds'], '.1f'):>6} | "
            f"{_g(row['time_ratio'], '.2f'):>7} {_g(row['r_ratio'], '.3g'):>7}")


def main(argv=None) -> list[dict]:
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.sim.params import SimParams

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default=None,
                    help=f"comma-separated, of {', '.join(KINDS)} "
                         f"(default: {', '.join(DEFAULT_SIZES)})")
    ap.add_argument("--sizes", default=None, help="comma-separated part counts (default: each "
                                                  "kind's own list)")
    ap.add_argument("--assemblies", default=None, help="comma-separated KIND:N pairs, run in this "
                                                       "order (instead of --kinds and --sizes)")
    ap.add_argument("--seed", type=int, default=11, help="the planning seed, every method")
    ap.add_argument("--assembly-seed", type=int, default=0, help="the assemblies' seed")
    ap.add_argument("--optimum-max-parts", type=int, default=12)
    ap.add_argument("--optimum-max-operations", type=int, default=3000,
                    help="skip the optimum when the AND/OR graph has more operations")
    ap.add_argument("--trials", type=int, default=None, help="simulator trials a score "
                                                             "(default: SimParams's, 100)")
    ap.add_argument("--workers", type=int, default=1, help="simulation processes a plan (default "
                    "1: in this process, as rap.plan.plan; rap-farm plan uses every CPU)")
    ap.add_argument("--json", default=None, help="write the rows to this file")
    ap.add_argument("--quick", action="store_true", help="a smoke run: " + ", ".join(
        f"{k} {'/'.join(map(str, v))}" for k, v in QUICK.items()) + ", 10 trials")
    a = ap.parse_args(argv)
    if a.quick:
        plan_of = [(k, (n,)) for k, ns in QUICK.items() for n in ns]
        trials = a.trials or 10
    elif a.assemblies:
        plan_of = [(k, (int(n),)) for k, n in (p.split(":") for p in a.assemblies.split(","))]
        unknown = [k for k, _ in plan_of if k not in KINDS]
        if unknown:
            ap.error(f"unknown kinds {', '.join(unknown)}; choose from {', '.join(KINDS)}")
        trials = a.trials
    else:
        kinds = a.kinds.split(",") if a.kinds else list(DEFAULT_SIZES)
        unknown = [k for k in kinds if k not in KINDS]
        if unknown:
            ap.error(f"unknown kinds {', '.join(unknown)}; choose from {', '.join(KINDS)}")
        sizes = [int(s) for s in a.sizes.split(",")] if a.sizes else None
        plan_of = [(k, sizes if sizes is not None else DEFAULT_SIZES.get(k, ())) for k in kinds]
        trials = a.trials
    params = SimParams() if trials is None else SimParams(trials=trials)
    load0 = os.getloadavg()
    print(f"plan_scale: {os.cpu_count()} CPUs, load average {load0[0]:.2f} at start; planning "
          f"seed {a.seed}, assembly seed {a.assembly_seed}, {params.trials} trials a score, "
          f"{a.workers} simulation process{'es' if a.workers > 1 else ''} a plan")
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    for method in ("search", "sim"):  # warm-up: the first plan loads the calibration, the engine
        _run(grid(4), method, model, a.seed, SimParams(trials=2))
    print(HEADER)
    rows = []
    for kind, sizes in plan_of:
        for kind_, n, asm in assemblies_for([kind], sizes, a.assembly_seed):
            if isinstance(asm, str):
                print(f"{kind} {n}: skipped ({asm})")
                continue
            row = {"kind": kind, "name": asm.name, "parts": len(asm),
                   "load": os.getloadavg()[0]}
            row["default"] = _run(asm, "search", model, a.seed, params, a.workers)
            row["sim"] = _run(asm, "sim", model, a.seed, params, a.workers)
            row["optimal"] = None
            if len(asm) <= a.optimum_max_parts:
                ops = _graph_operations(asm, a.seed, params, a.optimum_max_operations)
                if ops is not None:
                    row["optimal"] = _run(asm, "optimal", model, a.seed, params, a.workers)
                else:
                    row["optimal_skipped"] = (f"the graph has over {a.optimum_max_operations} "
                                              f"operations")
            d, g = row["default"], row["sim"]
            row["time_ratio"] = _ratio(d["seconds"], g["seconds"])
            row["r_ratio"] = _ratio(d["robustness"], g["robustness"])
            rows.append(row)
            print(line(row), flush=True)
            if a.json:  # after every row: a long run that is stopped keeps what it measured
                _write_json(a, argv, params, load0, rows)
            for m in ("default", "sim"):
                if row[m]["message"]:
                    print(f"    {m}: {row[m]['status']}: {row[m]['message']}")
    print()
    for s in summary(rows):
        print(s)
    load1 = os.getloadavg()
    print(f"load average {load1[0]:.2f} at the end (1-minute), {load1[2]:.2f} (15-minute)")
    if a.json:
        _write_json(a, argv, params, load0, rows)
    return rows


def _write_json(a, argv, params, load0, rows) -> None:
    """The rows, the command and the machine to ``a.json``, whole or not at all."""
    doc = {"command": " ".join(["python", "benchmarks/plan_scale.py",
                                *(argv if argv is not None else sys.argv[1:])]),
           "cpus": os.cpu_count(), "load_start": load0[0], "load_now": os.getloadavg()[0],
           "seed": a.seed, "assembly_seed": a.assembly_seed, "trials": params.trials,
           "workers": a.workers, "rows": rows, "summary": summary(rows)}
    tmp = Path(str(a.json) + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    tmp.replace(a.json)


if __name__ == "__main__":
    main()
