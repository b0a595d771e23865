"""The planner's CNN on a real assembly's operations: operations scored a second, by batch size.

    python benchmarks/cnn_operations.py [--assembly assemblies/cells/brick-wall-22.json]
        [--operations 1024] [--batches 4,64,512]

Scores the first ``--operations`` operations of the assembly's AND/OR graph with the shipped model
as ``plan`` did before the cascade (``OperationPredictor.load(..., engine="cnn")``, ``expected_score``: rendering, the
descriptors and the forward pass), in batches of each size, and prints operations a second and
the share of rendering. Also prints the graph's size and what scoring all of it would take at the
best rate: the floor of the exact search's time on that assembly, which scores most of the graph
(docs/RESULTS.md, "Real plans, timed"). The machine's CPU count and load average are printed:
the figures depend on what else runs.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    from rap.io import load_assembly
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.graph import reachable
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assembly", default=str(ROOT / "assemblies" / "cells" / "brick-wall-22.json"))
    ap.add_argument("--operations", type=int, default=1024)
    ap.add_argument("--batches", default="4,64,512")
    a = ap.parse_args()
    problem = PlanningProblem(load_assembly(a.assembly), SimParams())
    t = time.perf_counter()
    graph = reachable(problem, 10**6)
    ops = [op for c in graph.values() for op in c]
    print(f"{Path(a.assembly).name}: {len(graph)} subassemblies, {len(ops)} operations "
          f"(graph built in {time.perf_counter() - t:.2f} s); {os.cpu_count()} CPUs, load "
          f"{os.getloadavg()[0]:.1f}")
    cnn = OperationPredictor.load(ROOT / "rap" / "data" / "default_model.pt", engine="cnn")
    sample = ops[:a.operations]
    cnn.expected_score(problem, sample[:8])  # warm-up
    best = 0.0
    for size in (int(b) for b in a.batches.split(",")):
        cnn.render_seconds = 0.0
        t = time.perf_counter()
        for i in range(0, len(sample), size):
            cnn.expected_score(problem, sample[i:i + size])
        dt = time.perf_counter() - t
        best = max(best, len(sample) / dt)
        print(f"batch {size:5d}: {len(sample) / dt:6.0f} operations/s, rendering "
              f"{cnn.render_seconds / dt:.0%} of the time")
    print(f"all {len(ops)} operations at the best rate: {len(ops) / best:.1f} s")


if __name__ == "__main__":
    main()
