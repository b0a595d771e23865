"""Labelling-farm benchmark: throughput with 1 and 2 workers, Ray's overhead, driver memory.

    /work/venv/bin/python benchmarks/farm.py            # ~3 minutes on a 2-core machine
    /work/venv/bin/python benchmarks/farm.py --quick    # ~1 minute, smaller samples

Prints (ratios measured in one run):

1. operations per second with 1 and 2 simulation actors on the same operations (real simulator,
   ``--trials`` noisy trials, images rendered), and the speedup (target >= 1.8x on 2 cores);
2. Ray's overhead as a fraction of the time spent inside the simulator (target < 5%), two ways:
   (a) end to end: (wall time with 1 actor - wall time of the same loop in-process) / simulator time,
   (b) inside the pool: (actors x wall time - time inside the actors' task bodies) / simulator time;
3. the driver's resident memory at the start and at the end of a ``run_label`` of a few thousand
   operations (few trials, so that it is quick): it should stay flat, because rows are committed
   to Parquet shards as they arrive and never all held.

Starts its own local Ray with 2 CPUs and shuts it down at the end.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.io import load_assembly  # noqa: E402
from rap.enumerate import label_seed, select_operations  # noqa: E402
from rap.sim.params import SimParams  # noqa: E402
from tests.farm.test_scale import rss_mib  # noqa: E402  (one home: the scale test's)

NAMES = ["grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "triangles"]


def blank_render(assembly, operation, params=None, size: int = 64):
    """Used only while ``rap.render.images`` does not exist: the rows still carry 8 KiB images."""
    return np.zeros((2, size, size), np.uint8)


def sample(per_assembly: int, seed: int = 1):
    """The default mix: a seeded sample of ``per_assembly`` operations of each of the six."""
    out = []
    for n in NAMES:
        a = load_assembly(ROOT / "assemblies" / f"{n}.json")
        for op in select_operations(a, per_assembly, seed):
            out.append((a, op))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-assembly", type=int, default=25, help="operations per assembly (throughput)")
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--memory-ops", type=int, default=3000, help="operations of the memory run")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.per_assembly, args.memory_ops = 10, 1200

    import ray

    from rap.farm.actors import Backend
    from rap.farm.driver import LabelConfig, run_label
    from rap.farm.pool import SimPool

    have_render = importlib.util.find_spec("rap.render.images") is not None
    images = have_render
    backend = Backend()
    params = SimParams(trials=args.trials)
    work = sample(args.per_assembly)
    print(f"machine: {os.cpu_count()} CPUs; {len(work)} operations ({args.per_assembly} per assembly "
          f"x {len(NAMES)}), {args.trials} trials each, images {'on' if images else 'off (no renderer yet)'}")

    # -- in-process reference: the same loop without Ray ----------------------------------------
    from rap.sim.simulator import simulate

    render = None
    if images:
        from rap.render.images import render_pair as render
    fp = params.fingerprint()
    t0 = time.perf_counter()
    sim_direct = 0.0
    for a, op in work:
        t = time.perf_counter()
        simulate(a, op, params, np.random.default_rng(label_seed(op, a.geometry_hash, fp, 1)))
        sim_direct += time.perf_counter() - t
        if render is not None:
            render(a, op, params=params, size=64)
    direct_s = time.perf_counter() - t0
    print(f"in-process loop        {direct_s:7.2f} s  {len(work) / direct_s:7.2f} ops/s  "
          f"(simulator {sim_direct:.2f} s)")

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR",
             runtime_env={"env_vars": {"PYTHONPATH": str(ROOT)}})
    try:
        rates, walls, inner = {}, {}, {}
        for w in (1, 2):
            pool = SimPool(w, backend=backend)
            pool.ready()
            jobs = [j for a in {id(a): a for a, _ in work}.values()
                    for j in SimPool.jobs(a, [op for b, op in work if b is a], params, 1)]
            t0 = time.perf_counter()
            n = 0
            for res in pool.stream(jobs, params, images=images, total=len(jobs)):
                n += res.num_rows
            wall = time.perf_counter() - t0
            rates[w], walls[w] = n / wall, wall
            inner[w] = dict(pool.stats)
            pool.shutdown()
            st = inner[w]
            print(f"ray, {w} worker{'s' if w > 1 else ' '}        {wall:7.2f} s  {rates[w]:7.2f} ops/s  "
                  f"({st['tasks']} tasks, {st['ops'] / max(1, st['tasks']):.1f} ops/task, "
                  f"simulator {st['sim_s']:.2f} s)")
        print(f"speedup 2 vs 1 worker  {rates[2] / rates[1]:.2f}x   (target >= 1.8x)")
        print(f"throughput, 2 workers  {rates[2]:.1f} ops/s   (target >= 15 ops/s)")
        over_e2e = (walls[1] - direct_s) / sim_direct
        st1 = inner[1]
        over_pool = (1 * walls[1] - st1["task_s"]) / st1["sim_s"]
        print(f"ray overhead / simulator time: end-to-end {over_e2e:+.1%}, inside the pool "
              f"{over_pool:+.1%}   (target < 5%)")

        # -- driver memory over a few thousand operations ----------------------------------------
        per = max(1, args.memory_ops // len(NAMES))
        paths = tuple(str(ROOT / "assemblies" / f"{n}.json") for n in NAMES)
        samples: list[tuple[int, float]] = []

        def on_batch(summary):
            samples.append((summary.labelled, rss_mib()))

        with tempfile.TemporaryDirectory() as tmp:
            if images:
                cfg_backend = backend
            else:  # no renderer yet: blank images of the right size (see blank_render)
                cfg_backend = Backend(render="benchmarks.farm:blank_render")
            cfg = LabelConfig(assemblies=paths, out=str(Path(tmp) / "ds"), trials=2, seed=3,
                              max_ops_per_assembly=per, progress=False, flush_rows=256,
                              flush_seconds=10.0, backend=cfg_backend)
            rss0 = rss_mib()
            t0 = time.perf_counter()
            s = run_label(cfg, on_batch=on_batch)
            dt = time.perf_counter() - t0
            rss1 = rss_mib()
        first = next((r for n, r in samples if n >= 256), samples[0][1] if samples else rss0)
        peak = max((r for _, r in samples), default=rss1)
        print(f"driver memory, run_label of {s.labelled} operations (2 trials, {s.shards} shards, "
              f"{dt:.1f} s, {s.rate:.1f} ops/s):")
        print(f"  RSS before {rss0:.0f} MiB, after the first flush {first:.0f} MiB, "
              f"peak {peak:.0f} MiB, at the end {rss1:.0f} MiB "
              f"({(rss1 - first) / max(1, s.labelled - 256) * 1000:+.2f} MiB per 1000 rows "
              "after the first flush)")
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main()
