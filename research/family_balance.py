"""Robustness balance of the assembly families: the fraction of operations scoring >= 0.95.

For each family, ``--seeds`` assemblies (seeds 0, 1, ...) with the default options; from each, a
seeded sample of ``--ops`` operations (``sample``) out of every operation
of its AND/OR graph (mode 'all', the labelling farm's; mode 'online' where 'all' exceeds
``--max-all`` operations), each simulated with ``SimParams(trials=--trials)``. Prints one row per
family: assemblies, operations, the high fraction, the mean score, simulator seconds.

    python -m research.family_balance                 # 3 seeds x 15 operations, 50 trials
    python -m research.family_balance --families wall,pegs --seeds 5
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from rap.enumerate import label_seed
from rap.geometry.andor import and_or_graph
from rap.geometry.families import FAMILIES, generate
from rap.geometry.moving_sets import TooManyPartitions
from rap.geometry.ndbg import build_ndbg
from rap.sim.params import SimParams
from rap.seeds import derive_seed
from rap.sim.simulator import simulate

HIGH = 0.95


def operations(asm, max_all: int):
    """(mode, operations) of every reachable subassembly, deduplicated by content key."""
    ndbg = build_ndbg(asm)
    try:
        mode, graph = "all", and_or_graph(ndbg, "all", max_operations=max_all)
    except TooManyPartitions:
        mode, graph = "online", and_or_graph(ndbg, "online")
    gh = asm.geometry_hash
    ops = {}
    for subset in sorted(graph.partitions, key=lambda s: (len(s), sorted(s))):
        for p in graph.partitions[subset]:
            op = p.operation()
            ops.setdefault(op.key(gh), op)
    return mode, list(ops.values())


def sample(ops, k: int, root_seed: int, geometry_hash: str) -> list:
    """A seeded subset of ``k`` operations (all when ``k >= len(ops)``): those of smallest
    ``derive_seed(root_seed, key)``, in key order (what ``rap.enumerate`` sampled when this script
    was written). O(n log n)."""
    if k >= len(ops):
        return list(ops)
    key = lambda op: op.key(geometry_hash)  # noqa: E731
    ranked = sorted(ops, key=lambda op: (derive_seed(root_seed, key(op)), key(op)))
    return sorted(ranked[:k], key=key)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ops", type=int, default=15)
    ap.add_argument("--trials", type=int, default=50)
    ap.add_argument("--max-all", type=int, default=20_000)
    ap.add_argument("--verbose", "-v", action="store_true", help="print every operation's score")
    args = ap.parse_args(argv)
    params = SimParams(trials=args.trials)
    fp = params.fingerprint()
    print(f"{'family':10s} {'asm':>3s} {'ops':>4s} {'high':>5s} {'mean':>5s} {'sim s':>6s}  modes")
    for name in args.families.split(","):
        scores, modes, sim_s = [], [], 0.0
        for seed in range(args.seeds):
            asm = generate(name, seed)
            mode, ops = operations(asm, args.max_all)
            modes.append(mode)
            gh = asm.geometry_hash
            for op in sample(ops, args.ops, 0, gh):
                t = time.perf_counter()
                r = simulate(asm, op, params, rng=np.random.default_rng(label_seed(op, gh, fp, 0)))
                sim_s += time.perf_counter() - t
                scores.append(r.score)
                if args.verbose:
                    print(f"  {asm.name} {r.score:.2f} {op.describe()}")
        s = np.array(scores)
        print(f"{name:10s} {args.seeds:3d} {len(s):4d} {np.mean(s >= HIGH):5.2f} {s.mean():5.2f} "
              f"{sim_s:6.1f}  {','.join(modes)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
