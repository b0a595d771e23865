"""The sampled operation stream against the exhaustive space, on the six reference assemblies.

For each assembly: the exhaustive operation space (mode ``all``, one direction per range) and the
first K operations of the seeded sampled stream (``rap.enumerate.iter_sampled_operations``,
K = half the space, at most 1000). Prints, per assembly, the total variation distance (TVD, 0 =
identical, 1 = disjoint) between the two distributions of: subassembly size, moving-set size
relative to the subassembly (4 bins), removal direction (8 bins of 45 degrees); and the sample's
share of high-level operations (subassembly = the whole assembly). Then the pooled histograms.

    python -m research.benchmarks.sampler [--seed 7] [--max-k 1000]
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

from rap.io import load_assembly  # noqa: E402
from rap.enumerate import enumerate_operations, iter_sampled_operations  # noqa: E402

NAMES = ["grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "triangles"]


def features(op, n_parts: int) -> dict:
    dx, dy = op.direction
    angle = (math.degrees(math.atan2(-dy, -dx)) + 360.0) % 360.0  # removal direction
    size = len(op.subassembly)
    return {"size": size, "moving": min(3, int(4 * len(op.moving) / size)),
            "direction": int(angle // 45) % 8, "whole": size == n_parts}


def dist(values) -> Counter:
    c = Counter(values)
    n = sum(c.values())
    return Counter({k: v / n for k, v in c.items()})


def tvd(p: Counter, q: Counter) -> float:
    return 0.5 * sum(abs(p.get(k, 0.0) - q.get(k, 0.0)) for k in set(p) | set(q))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--max-k", type=int, default=1000)
    args = ap.parse_args(argv)
    print(f"{'assembly':13s} {'space':>6s} {'K':>5s} {'s':>5s} {'TVD size':>8s} {'TVD moving':>10s} "
          f"{'TVD dir':>7s} {'whole: space':>12s} {'sample':>6s}")
    pooled = {"space": [], "sample": []}
    for name in NAMES:
        a = load_assembly(ROOT / "assemblies" / f"{name}.json")
        space = enumerate_operations(a)
        k = min(args.max_k, len(space) // 2)
        t0 = time.perf_counter()
        sample = list(itertools.islice(iter_sampled_operations(a, root_seed=args.seed), k))
        dt = time.perf_counter() - t0
        fs = [features(op, len(a)) for op in space]
        fq = [features(op, len(a)) for op in sample]
        row = [tvd(dist(f[key] for f in fs), dist(f[key] for f in fq))
               for key in ("size", "moving", "direction")]
        whole_s = sum(f["whole"] for f in fs) / len(fs)
        whole_q = sum(f["whole"] for f in fq) / len(fq)
        print(f"{name:13s} {len(space):6d} {k:5d} {dt:5.2f} {row[0]:8.2f} {row[1]:10.2f} "
              f"{row[2]:7.2f} {whole_s:12.2f} {whole_q:6.2f}")
        pooled["space"] += [f["size"] for f in fs]
        pooled["sample"] += [f["size"] for f in fq]
    print("\nsubassembly size, share of operations (pooled over the six):")
    ds, dq = dist(pooled["space"]), dist(pooled["sample"])
    print("  size   " + " ".join(f"{s:5d}" for s in range(2, 10)))
    print("  space  " + " ".join(f"{ds.get(s, 0):5.2f}" for s in range(2, 10)))
    print("  sample " + " ".join(f"{dq.get(s, 0):5.2f}" for s in range(2, 10)))


if __name__ == "__main__":
    main()
