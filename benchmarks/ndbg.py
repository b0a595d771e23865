"""Benchmark: exact NDBG build and all-cells online partitions vs number of parts.

Run: ``python benchmarks/ndbg.py [--repeat R]``. Prints one row per assembly (k x k grids,
k = 2..10, and random tilings of 10..100 parts): parts, cells, build seconds, seconds for
``online_partitions`` of the whole assembly (every cell), and the fitted growth exponent of the
build time (least squares of log time on log n) per family. Times are the best of R runs.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from rap.geometry.families.simple import grid, random_tiling
from rap.geometry.ndbg import build_ndbg
from rap.geometry.partitions import online_partitions


def _best(fn, repeat):
    best, out = math.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _exponent(ns, ts):
    x = np.log(np.asarray(ns, float))
    y = np.log(np.asarray(ts, float))
    return float(np.polyfit(x, y, 1)[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    families = {
        "grid": [(f"grid {k}x{k}", grid(k)) for k in range(2, 11)],
        "tiling": [(f"tiling {n}", random_tiling(n, np.random.default_rng(n)))
                   for n in (10, 20, 40, 60, 80, 100)],
    }
    print(f"{'assembly':<14}{'parts':>6}{'cells':>8}{'build s':>10}{'online s':>10}{'partitions':>12}")
    for fam, items in families.items():
        ns, ts = [], []
        for label, asm in items:
            tb, nd = _best(lambda: build_ndbg(asm), args.repeat)
            to, ps = _best(lambda: online_partitions(nd, nd.ids), args.repeat)
            ns.append(len(asm))
            ts.append(tb)
            print(f"{label:<14}{len(asm):>6}{len(nd.cells):>8}{tb:>10.4f}{to:>10.4f}{len(ps):>12}")
        print(f"{fam}: fitted build-time exponent (log-log least squares) = {_exponent(ns, ts):.2f}")


if __name__ == "__main__":
    main()
