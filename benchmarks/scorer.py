"""The default scorer against the CNN alone on a whole AND/OR graph: operations a second, one run.

    python benchmarks/scorer.py [--assembly assemblies/cells/brick-wall-22.json]
        [--batch subassembly|N] [--repeats 3] [--blas-threads N]

Enumerates the assembly's AND/OR graph (``rap.plan.graph.reachable``, as
``benchmarks/cnn_operations.py`` does; 8,903 operations on the 22-brick wall) and scores every
operation's ``prob_high_and_expected`` (what the planners ask: rendering, descriptors and the
forward pass included) with

* the default scorer, ``OperationPredictor.load(shipped, engine="auto")`` (the cascade of
  ``rap.model.inference.cascade``), and
* the CNN alone, ``OperationPredictor.load(shipped, engine="cnn")`` (numpy engine),

each freshly loaded per repeat (their per-assembly tables built inside the timing), the two
alternating ``--repeats`` times; the best time of each counts. ``--batch subassembly`` (default)
asks one subassembly's candidate operations per call, as the exact search scores lazily (3.4
operations a call on the wall); a number asks that many operations a call. Prints both rates,
the share of operations the cascade sent to the CNN, the agreement of the two (mean |difference|
of the expected scores, P(high) on the same side of 0.5) and ``scorer speedup: X`` (the CNN's
time over the default's). CPU count and load average are printed: the ratio is what to read.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    from rap.io import load_assembly
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.graph import reachable
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assembly", default=str(ROOT / "assemblies" / "cells" / "brick-wall-22.json"))
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    ap.add_argument("--batch", default="subassembly")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--blas-threads", type=int, default=None,
                    help="limit BLAS threads (threadpoolctl) for both scorers [default: as plan "
                         "runs, no limit]")
    a = ap.parse_args()
    if a.blas_threads:
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=a.blas_threads, user_api="blas")
    problem = PlanningProblem(load_assembly(a.assembly), SimParams())
    t = time.perf_counter()
    graph = reachable(problem, 10**6)
    if a.batch == "subassembly":
        batches = [list(c) for c in graph.values() if c]
    else:
        ops = [op for c in graph.values() for op in c]
        size = int(a.batch)
        batches = [ops[i:i + size] for i in range(0, len(ops), size)]
    n = sum(len(b) for b in batches)
    print(f"{Path(a.assembly).name}: {len(graph)} subassemblies, {n} operations in {len(batches)} "
          f"calls of {n / len(batches):.1f} (graph built in {time.perf_counter() - t:.2f} s); "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}, BLAS threads "
          f"{a.blas_threads or 'unlimited'}")

    def run(engine: str):
        scorer = OperationPredictor.load(a.model, engine=engine)
        t = time.perf_counter()
        got = [scorer.prob_high_and_expected(problem, b) for b in batches]
        dt = time.perf_counter() - t
        return dt, scorer, np.concatenate([g[0] for g in got]), np.concatenate([g[1] for g in got])

    best = {"auto": np.inf, "cnn": np.inf}
    out = {}
    for r in range(a.repeats):
        for engine in ("cnn", "auto"):
            dt, scorer, prob, expected = run(engine)
            best[engine] = min(best[engine], dt)
            out[engine] = (scorer, prob, expected)
            print(f"  repeat {r + 1}, {engine:4s}: {dt:6.2f} s", flush=True)
    default = out["auto"][0]
    if getattr(default, "engine", None) != "cascade":
        raise SystemExit("engine='auto' did not give the cascade: is the descriptor model "
                         "rap/data/default_model.scorer.npz missing or stale?")
    share = default.counts["cnn"] / max(1, sum(default.counts.values()))
    diff = np.abs(out["auto"][2] - out["cnn"][2]).mean()
    same = np.mean((out["auto"][1] >= 0.5) == (out["cnn"][1] >= 0.5))
    print(f"CNN alone:      {n / best['cnn']:8.0f} operations/s ({best['cnn']:.2f} s)")
    print(f"default scorer: {n / best['auto']:8.0f} operations/s ({best['auto']:.2f} s; "
          f"{share:.1%} of operations sent to the CNN, band {default.band})")
    print(f"agreement: mean |expected difference| {diff:.4f}, same class {same:.1%}")
    print(f"scorer speedup: {best['cnn'] / best['auto']:.1f}")


if __name__ == "__main__":
    main()
