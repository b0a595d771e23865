"""Benchmark of reading and validating an assembly at the input bounds (rap.assembly.LIMITS).

Prints, measured in one run on this machine:

* the hostile numbers of the past (``1e-1000000``, ``1e10000000``) refused: seconds each;
* a star ring (every edge's box meets a quarter of the others: the worst case of the ring check)
  of 1,000 to 10,000 vertices: seconds of the batch check (``rap.geometry.batch``: numpy sweep,
  float filter, exact fallback) and of the pairwise exact loop (up to 2,000 vertices; beyond,
  extrapolated as q^2), and their ratio;
* ``load_assembly`` (read + validate) of the 100-part grid (``rap.geometry.families.simple.grid(10)``) and of the largest file within the
  bounds that this benchmark writes (10 star parts of 10,000 vertices: 100,000 vertices).

    python benchmarks/validation.py [--max-vertices 10000]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.assembly import AssemblyError  # noqa: E402
from rap.geometry import validation  # noqa: E402
from rap.io import load_assembly  # noqa: E402


def star(q: int, outer: float, inner: float, cx: float = 0.0):
    return [[round(cx + (outer if k % 2 == 0 else inner) * math.cos(2 * math.pi * k / q)),
             round((outer if k % 2 == 0 else inner) * math.sin(2 * math.pi * k / q))]
            for k in range(q)]


def timed(fn, *args):
    t = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t


def pairwise(ring):
    old = validation._BATCH_MIN
    validation._BATCH_MIN = 10 ** 9
    try:
        return validation.ring_is_simple(ring)
    finally:
        validation._BATCH_MIN = old


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-vertices", type=int, default=10_000)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    tangram = (ROOT / "assemblies" / "unseen" / "tangram.json").read_text()
    for number in ("1e-1000000", "1e10000000"):
        path = tmp / "hostile.json"
        path.write_text(tangram.replace("[0,0]", f"[{number},0]", 1))
        t = time.perf_counter()
        try:
            load_assembly(path)
        except AssemblyError as exc:
            print(f"hostile {number:>11}: refused in {time.perf_counter() - t:.4f} s ({exc.problem})")
    print(f"{'star ring':>10} {'batch s':>9} {'pairwise s':>11} {'ratio':>7}")
    base = None
    for q in (1000, 2000, 5000, args.max_vertices):
        ring = [tuple(p) for p in star(q, 10 ** 9, 10 ** 6)]
        ok, t_batch = timed(validation.ring_is_simple, ring)
        assert ok
        if q <= 2000:
            _, t_pair = timed(pairwise, ring)
            base = (q, t_pair)
            note = ""
        else:
            t_pair = base[1] * (q / base[0]) ** 2
            note = " (extrapolated)"
        print(f"{q:>10} {t_batch:>9.2f} {t_pair:>11.2f} {t_pair / t_batch:>7.1f}{note}")
    from rap.geometry.families.simple import grid
    from rap.io import assembly_to_json

    path = tmp / "grid100.json"
    path.write_text(json.dumps(assembly_to_json(grid(10))))
    asm, t = timed(load_assembly, path)
    print(f"load_assembly of the {len(asm)}-part grid: {t:.3f} s")
    parts = [{"id": f"s{k}", "polygon": star(args.max_vertices, 10 ** 7, 10 ** 4,
                                               cx=k * 3 * 10 ** 7)} for k in range(10)]
    big = tmp / "big.json"
    big.write_text(json.dumps({"parts": parts}))
    asm, t = timed(load_assembly, big)
    print(f"load_assembly of {sum(len(p.outer) for p in asm.parts)} vertices in 10 star parts "
          f"({big.stat().st_size / 2**20:.1f} MiB): {t:.2f} s")


if __name__ == "__main__":
    main()
