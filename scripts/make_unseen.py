"""A benchmark of assemblies no model here was trained on: new kinds and fresh family seeds.

    python scripts/make_unseen.py assemblies        # writes assemblies/unseen/*.json
    python scripts/make_unseen.py label [--workers 2]   # labels them into datasets/unseen

**New kinds** (no generated family makes them): ``tangram`` (the seven classic pieces in a 40 x 40
square; 45-degree edges), ``pentomino-6x10`` (the twelve pentominoes tiling a 6 x 10 rectangle;
the first tiling found by a deterministic backtracking search), ``basketweave`` (twelve 2 x 1
bricks in alternating pairs, a paving pattern). **Fresh seeds** of the ten generated families:
per family the first seed from 100 on (the corpus holds seeds 0-35) whose assembly has 9 to 12
parts.

Labelled like the corpus (`rap-farm label`, root seed 20190527, 100 trials, at most 420 operations
per assembly, three directions per merged range) into ``datasets/unseen`` (not committed: it is a
test set, and rebuilt by this script). Scored with `rap-farm score MODEL datasets/unseen`.
All coordinates are integers.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT_DIR = ROOT / "assemblies" / "unseen"
DATASET = ROOT / "datasets" / "unseen"
SEED = 20190527
FRESH_FROM, FRESH_PARTS = 100, (9, 12)

TANGRAM = {  # the classic dissection of a 4 x 4 square, scaled by 10
    "large-a": [(0, 0), (40, 0), (20, 20)],
    "large-b": [(0, 0), (20, 20), (0, 40)],
    "small-a": [(40, 0), (40, 20), (30, 10)],
    "square": [(30, 10), (40, 20), (30, 30), (20, 20)],
    "small-b": [(20, 20), (30, 30), (10, 30)],
    "parallelogram": [(0, 40), (10, 30), (30, 30), (20, 40)],
    "medium": [(40, 20), (40, 40), (20, 40)],
}

PENTOMINOES = {  # cells of each free pentomino in one orientation
    "F": [(1, 0), (2, 0), (0, 1), (1, 1), (1, 2)], "I": [(0, 0), (0, 1), (0, 2), (0, 3), (0, 4)],
    "L": [(0, 0), (0, 1), (0, 2), (0, 3), (1, 3)], "N": [(1, 0), (1, 1), (0, 2), (1, 2), (0, 3)],
    "P": [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2)], "T": [(0, 0), (1, 0), (2, 0), (1, 1), (1, 2)],
    "U": [(0, 0), (2, 0), (0, 1), (1, 1), (2, 1)], "V": [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)],
    "W": [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2)], "X": [(1, 0), (0, 1), (1, 1), (2, 1), (1, 2)],
    "Y": [(1, 0), (0, 1), (1, 1), (1, 2), (1, 3)], "Z": [(0, 0), (1, 0), (1, 1), (1, 2), (2, 2)],
}


def _orientations(cells):
    out = set()
    for flip in (False, True):
        pts = [(-x, y) if flip else (x, y) for x, y in cells]
        for _ in range(4):
            pts = [(-y, x) for x, y in pts]
            mx, my = min(x for x, _ in pts), min(y for _, y in pts)
            out.add(tuple(sorted((x - mx, y - my) for x, y in pts)))
    return sorted(out)


def pentomino_tiling(cols: int = 10, rows: int = 6) -> dict[str, list[tuple[int, int]]]:
    """The first tiling of a ``cols`` x ``rows`` rectangle by the twelve pentominoes found by
    backtracking (the first empty cell in column-major order, so along the short side first;
    pieces and orientations in sorted order): deterministic, a fraction of a second."""
    shapes = {k: _orientations(v) for k, v in sorted(PENTOMINOES.items())}
    anchored = {k: [[(x - o0[0], y - o0[1]) for x, y in o] for o in os
                    for o0 in [min(o)]] for k, os in shapes.items()}  # min: column-major first
    order = [(x, y) for x in range(cols) for y in range(rows)]
    grid: dict[tuple[int, int], str] = {}
    placed: dict[str, list[tuple[int, int]]] = {}

    def solve(i: int) -> bool:
        while i < len(order) and order[i] in grid:
            i += 1
        if i == len(order):
            return True
        cx, cy = order[i]
        for name, orients in anchored.items():
            if name in placed:
                continue
            for o in orients:
                cells = [(cx + x, cy + y) for x, y in o]
                if all(0 <= x < cols and 0 <= y < rows and (x, y) not in grid for x, y in cells):
                    for c in cells:
                        grid[c] = name
                    placed[name] = cells
                    if solve(i + 1):
                        return True
                    for c in cells:
                        del grid[c]
                    del placed[name]
        return False

    if not solve(0):
        raise RuntimeError("no tiling")
    return placed


def basketweave(blocks_x: int = 3, blocks_y: int = 2, unit: int = 10) -> dict[str, list]:
    """Bricks 2 x 1 (units) in 2 x 2 blocks, each block's pair turned 90 degrees from its
    neighbours'."""
    parts = {}
    for bx in range(blocks_x):
        for by in range(blocks_y):
            x0, y0 = 2 * bx * unit, 2 * by * unit
            for k in range(2):
                if (bx + by) % 2 == 0:  # two horizontal bricks
                    r = (x0, y0 + k * unit, x0 + 2 * unit, y0 + (k + 1) * unit)
                else:  # two vertical bricks
                    r = (x0 + k * unit, y0, x0 + (k + 1) * unit, y0 + 2 * unit)
                parts[f"b{bx}{by}{k}"] = [(r[0], r[1]), (r[2], r[1]), (r[2], r[3]), (r[0], r[3])]
    return parts


def make_assemblies() -> list[Path]:
    from rap.assembly import Assembly, assembly_to_json
    from rap.geometry.families import FAMILIES, generate
    from rap.geometry.families.base import make_part, verify
    from rap.geometry.families.packings import union_ring

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    kinds = {"tangram": TANGRAM, "basketweave": basketweave()}
    tiling = pentomino_tiling()
    kinds["pentomino-6x10"] = {name: union_ring([(x * 10, y * 10, x * 10 + 10, y * 10 + 10)
                                                 for x, y in cells])
                               for name, cells in tiling.items()}
    asms = []
    for name, parts in kinds.items():
        a = Assembly(name, tuple(make_part(pid, pts) for pid, pts in parts.items()),
                     family="unseen")
        verify(a)
        asms.append(a)
    for family in FAMILIES:
        seed = FRESH_FROM
        while not FRESH_PARTS[0] <= len(a := generate(family, seed)) <= FRESH_PARTS[1]:
            seed += 1
        asms.append(a)
    paths = []
    for a in asms:
        p = OUT_DIR / f"{a.name}.json"
        p.write_text(json.dumps(assembly_to_json(a), separators=(",", ":")) + "\n")
        paths.append(p)
        print(f"{p}: {len(a)} parts")
    return paths


def label(workers: int | None) -> None:
    paths = sorted(OUT_DIR.glob("*.json"))
    geometry = DATASET / "_assemblies"  # for views rendered again from geometry (the close-up)
    geometry.mkdir(parents=True, exist_ok=True)
    for p in paths:
        (geometry / p.name).write_bytes(p.read_bytes())
    cmd = ["rap-farm", "label", *map(str, paths), "--out", str(DATASET), "--seed", str(SEED),
           "--trials", "100", "--max-ops-per-assembly", "420", "--directions-per-range", "3"]
    if workers:
        cmd += ["--workers", str(workers)]
    print(" ".join(cmd), flush=True)
    sys.exit(subprocess.call(cmd))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("assemblies", "label"))
    ap.add_argument("--workers", type=int, default=None)
    a = ap.parse_args(argv)
    if a.what == "assemblies":
        make_assemblies()
    else:
        label(a.workers)


if __name__ == "__main__":
    main()
