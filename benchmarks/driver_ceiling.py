"""The labelling driver's ceiling: operations/s its own process can select, dispatch and write.

    python benchmarks/driver_ceiling.py            # ~2 minutes on a 2-core machine

``run_label`` on four assemblies (the 100-part grid, a 30-cell convex tiling, tangram, pentomino
6x10; ``--max-ops-per-assembly 4000``: about 10,400 operations) with a simulator that returns at
once (``null_simulate``: no physics, a seeded score) and a blank renderer (``--batch-size 9``:
tasks the size the real simulator's take), once with selection in
the driver's thread (``selection_tasks=0``) and once in parallel Ray tasks (``rap.farm.prefetch``),
each ``--repeats`` times. Printed per run: operations, the labelling rate (bound on this machine by
whatever shares its two cores), the driver process's CPU time per operation (``getrusage``: the
driver's own threads only, not the Ray workers'), and the ceiling that implies for a driver with a
core to itself: ``1 / (CPU seconds per operation)``. The last line is ``driver ceiling: N
operations/s`` (parallel selection, the best run) and how many cores that feeds at the real
simulator's rate (``--sim-ops-per-core``, 9 operations/s a core: docs/RESULTS.md).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def null_simulate(assembly, operation, params, rng):
    """No physics: a seeded score at once (the contract of ``rap.sim.simulator.simulate``)."""
    from rap.sim.simulator import SimResult

    s = int(rng.integers(params.trials + 1))
    return SimResult(s, params.trials, s / params.trials, 0.0)


def blank_render(assembly, operation, params=None, size: int = 64):
    """A blank image pair (rows of 8 KiB, as real ones)."""
    import numpy as np

    return np.zeros((2, size, size), np.uint8)


def assemblies(tmp: Path) -> list[str]:
    from rap.geometry.families import generate
    from rap.geometry.families.simple import grid
    from rap.io import assembly_to_json

    (tmp / "grid100.json").write_text(json.dumps(assembly_to_json(grid(10))))
    (tmp / "convex30.json").write_text(json.dumps(assembly_to_json(
        generate("convex", 0, rows=5, cols=6, cell="quad"))))
    unseen = ROOT / "assemblies" / "unseen"
    return [str(tmp / "grid100.json"), str(tmp / "convex30.json"), str(unseen / "tangram.json"),
            str(unseen / "pentomino-6x10.json")]


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(repeats: int = 2, max_ops: int = 4000, workers: int = 1,
            batch_size: int | None = None) -> dict[str, float]:
    """Time ``run_label`` both ways on the connected Ray (printing a line a run); the best
    ceiling of each way, operations/s."""
    from rap.farm.driver import LabelConfig, prepare, run_label
    from rap.labelling.rows import Backend

    tmp = Path(tempfile.mkdtemp())
    files = assemblies(tmp)
    backend = Backend(simulate="benchmarks.driver_ceiling:null_simulate",
                      render="benchmarks.driver_ceiling:blank_render", warm_up="")
    best: dict[str, float] = {}
    try:
        for _ in range(repeats):
            for tasks, how in ((0, "driver thread"), (None, "parallel tasks")):
                out = tmp / "out"
                shutil.rmtree(out, ignore_errors=True)
                cfg = LabelConfig(assemblies=tuple(files), out=str(out), workers=workers,
                                  trials=5, max_ops_per_assembly=max_ops, backend=backend,
                                  progress=False, flush_rows=4096, selection_tasks=tasks,
                                  batch_size=batch_size)
                c0, t0 = cpu_s(), time.perf_counter()
                s = run_label(cfg, prepare(cfg))
                cpu, wall = cpu_s() - c0, time.perf_counter() - t0
                ceiling = s.labelled / cpu
                best[how] = max(best.get(how, 0.0), ceiling)
                print(f"selection in the {how:14s}: {s.labelled} operations, {s.rate:6.0f} ops/s "
                      f"labelling ({wall:.1f} s wall), driver CPU {1e6 * cpu / s.labelled:5.0f} "
                      f"us/op -> {ceiling:6.0f} ops/s with a core to itself; peak RSS "
                      f"{s.peak_rss_mib:.0f} MiB", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return best


def ceiling_line(best: dict[str, float], sim_ops_per_core: float = 9.0) -> str:
    c = best["parallel tasks"]
    return (f"driver ceiling: {c:.0f} operations/s (selection in parallel tasks; in the driver's "
            f"thread {best['driver thread']:.0f}); it feeds about {c / sim_ops_per_core:.0f} "
            f"cores at {sim_ops_per_core:g} simulated operations/s a core")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-ops", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--sim-ops-per-core", type=float, default=9.0)
    ap.add_argument("--batch-size", type=int, default=None,
                    help="operations a task (default: adaptive, 64 with this simulator; the real "
                         "simulator's tasks of about 1 s hold about 9)")
    args = ap.parse_args()
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        best = measure(args.repeats, args.max_ops, args.workers, args.batch_size)
    finally:
        ray.shutdown()
    print(ceiling_line(best, args.sim_ops_per_core))


if __name__ == "__main__":
    main()
