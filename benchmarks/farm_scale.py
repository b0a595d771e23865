"""Scaling of the labelling farm with its workers: operations/s of 1 to 8, and the ratio to linear.

    python benchmarks/farm_scale.py                  # 1..8 actors of 1 logical CPU, local Ray (~3 min)
    python benchmarks/farm_scale.py --fake-nodes     # 1..8 nodes of Ray's fake autoscaling cluster
    python benchmarks/farm_scale.py --ray-data       # and Ray Data's actor pool against SimPool

The simulator (``fixed_time_simulate``) sleeps ``--op-ms`` per operation and does nothing else, and
the renderer returns a blank image pair (rows of 8 KiB, as real ones), so eight workers run
concurrently on a 2-core machine and the figures measure the farm (batching, dispatch, transfer of
rows, the driver's loop), not the physics. Each worker count labels ``--ops-per-worker`` operations
per worker (a seeded sample of the six reference assemblies) on a ``SimPool`` whose workers have
all started; the rate is operations over the stream's wall time, and the ratio to linear is
``rate(w) / (w * rate(1))`` (target: within 10%, i.e. >= 0.90).

``--fake-nodes`` starts ``tests/farm/fake_cluster.py``'s cluster with eight nodes of one CPU (the
head and seven workers, all started before timing) and gives each actor a node of its own
(``SPREAD``): rows then cross raylets and object stores, as on a real cluster. ``--ray-data``
times small batches (what the planning service sends) on Ray Data's autoscaling actor pool
(``map_batches``, ``concurrency=(1, 2)``) and on a warm ``SimPool``: the measurement behind the
choice of ``SimPool`` (``rap/farm/pool.py``).

Starts its own Ray (or fake cluster) and stops it at the end.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.enumerate import select_operations  # noqa: E402
from rap.io import load_assembly  # noqa: E402
from rap.sim.params import SimParams  # noqa: E402
from rap.sim.simulator import SimResult  # noqa: E402

NAMES = ["grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "triangles"]


def fixed_time_simulate(assembly, operation, params, rng):
    """Sleep ``params.time_limit_s`` milliseconds (the benchmark's ``--op-ms``); a seeded score."""
    time.sleep(params.time_limit_s * 1e-3)
    s = int(rng.binomial(params.trials, 0.5))
    return SimResult(s, params.trials, s / params.trials, params.time_limit_s * 1e-3)


def blank_render(assembly, operation, params=None, size: int = 64):
    return np.zeros((2, size, size), np.uint8)


def sample(n: int, seed: int = 1) -> list:
    """``n`` operations, a seeded sample spread over the six reference assemblies."""
    per = -(-n // len(NAMES))
    work = []
    for name in NAMES:
        a = load_assembly(ROOT / "assemblies" / f"{name}.json")
        work += [(a, op) for op in select_operations(a, per, seed)]
    if len(work) < n:
        raise SystemExit(f"only {len(work)} operations in the sample; ask for fewer")
    return work[:n]


def jobs_of(work, params, root_seed: int = 1):
    from rap.farm.pool import SimPool

    by = {}
    for a, op in work:
        by.setdefault(a.geometry_hash, (a, []))[1].append(op)
    return [j for a, ops in by.values() for j in SimPool.jobs(a, ops, params, root_seed)]


def machine_busy() -> tuple[float, float]:
    """(busy, total) CPU seconds of the whole machine so far (``/proc/stat``; zeros elsewhere)."""
    try:
        with open("/proc/stat") as fh:
            f = [float(x) for x in fh.readline().split()[1:]]
    except OSError:
        return 0.0, 0.0
    idle = f[3] + (f[4] if len(f) > 4 else 0.0)  # idle + iowait
    return sum(f) - idle, sum(f)


def scaling(counts, ops_per_worker: int, params, backend) -> dict[int, tuple[int, float]]:
    from rap.farm.pool import SimPool

    work = sample(max(counts) * ops_per_worker)
    out = {}
    print(f"{'workers':>7} {'ops':>5} {'seconds':>8} {'ops/s':>8} {'linear':>8} {'ratio':>6}  nodes"
          f"  machine busy")
    for w in counts:
        jobs = jobs_of(work[:w * ops_per_worker], params)
        with SimPool(w, backend=backend) as pool:
            nodes = {i["node"] for i in pool.ready(timeout_s=600)}
            b0, t0 = machine_busy(), time.perf_counter()
            n = sum(res.num_rows for res in pool.stream(jobs, params, images=True,
                                                        total=len(jobs)))
            dt, b1 = time.perf_counter() - t0, machine_busy()
        out[w] = (n, dt)
        rate = n / dt
        one = out[counts[0]][0] / out[counts[0]][1] / counts[0]
        print(f"{w:7d} {n:5d} {dt:8.2f} {rate:8.2f} {w * one:8.2f} {rate / (w * one):6.2f}  "
              f"{len(nodes):5d}  {(b1[0] - b0[0]) / max(b1[1] - b0[1], 1e-9):6.0%}", flush=True)
    return out


def compare_ray_data(params, backend, n_ops: int = 8, rounds: int = 5) -> None:
    """Latency of one small batch: Ray Data's autoscaling actor pool against a warm SimPool."""
    import logging

    import ray
    import ray.data

    from rap.farm.pool import SimPool

    ray.data.DataContext.get_current().enable_progress_bars = False
    logging.getLogger("ray.data").setLevel(logging.WARNING)
    op_s = params.time_limit_s * 1e-3

    class Sim:
        def __call__(self, batch):
            time.sleep(op_s * len(batch["id"]))
            return batch

    ideal = n_ops * op_s / 2
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        ray.data.range(n_ops).map_batches(Sim, concurrency=(1, 2), batch_size=n_ops // 2,
                                          num_cpus=1).take_all()
        times.append(time.perf_counter() - t)
    a = load_assembly(ROOT / "assemblies" / "triangles.json")
    ops = list(select_operations(a, n_ops * rounds, 2))
    with SimPool(2, backend=backend) as pool:
        pool.ready(timeout_s=600)
        mine = []
        for r in range(rounds):
            t = time.perf_counter()
            pool.score(a, ops[r * n_ops:(r + 1) * n_ops], params, 1)
            mine.append(time.perf_counter() - t)
    print(f"one batch of {n_ops} operations of {op_s * 1e3:.0f} ms on 2 workers (ideal "
          f"{ideal * 1e3:.0f} ms):")
    print(f"  Ray Data map_batches, actor pool (1, 2): first {times[0]:.2f} s, then median "
          f"{np.median(times[1:]):.2f} s per batch")
    print(f"  SimPool.score on warm actors:           first {mine[0]:.2f} s, then median "
          f"{np.median(mine[1:]):.3f} s per batch")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--op-ms", type=float, default=100.0, help="simulated milliseconds per operation")
    ap.add_argument("--ops-per-worker", type=int, default=40)
    ap.add_argument("--max-workers", type=int, default=8)
    ap.add_argument("--counts", default=None, help="worker counts to time, e.g. 1,8 (default: 1..max)")
    ap.add_argument("--fake-nodes", action="store_true", help="one node of Ray's fake cluster per worker")
    ap.add_argument("--ray-data", action="store_true", help="also compare with Ray Data's actor pool")
    args = ap.parse_args()

    import ray

    from rap.farm.actors import Backend

    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    backend = Backend(simulate="benchmarks.farm_scale:fixed_time_simulate",
                      render="benchmarks.farm_scale:blank_render", warm_up="")
    params = SimParams(trials=10, time_limit_s=args.op_ms)  # time_limit_s: the sleep, in ms
    counts = (sorted({int(c) for c in args.counts.split(",")}) if args.counts
              else list(range(1, args.max_workers + 1)))
    if counts[0] != 1 or counts[-1] > args.max_workers:
        raise SystemExit("--counts: from 1 to --max-workers")
    cluster = None
    try:
        if args.fake_nodes:
            os.environ.setdefault("RAY_AUTH_TOKEN", os.urandom(32).hex())  # the cluster's token
            from tests.farm.fake_cluster import FakeCluster

            cluster = FakeCluster(max_workers=args.max_workers - 1,
                                  min_workers=args.max_workers - 1, idle_timeout_minutes=60)
            cluster.start()
            cluster.connect()
            cluster.wait_nodes(lambda ns: len(ns) >= args.max_workers, timeout_s=600)
            where = f"{args.max_workers} nodes of Ray's fake autoscaling cluster (1 CPU each)"
        else:
            ray.init(num_cpus=args.max_workers, include_dashboard=False, log_to_driver=False,
                     logging_level="ERROR", runtime_env={"env_vars": {"PYTHONPATH": str(ROOT)}})
            where = f"a local Ray with {args.max_workers} logical CPUs"
        print(f"machine: {os.cpu_count()} cores; {where}; simulator sleeps {args.op_ms:g} ms per "
              f"operation; {args.ops_per_worker} operations per worker")

        if not args.fake_nodes:  # a simulator that returns at once (benchmarks/driver_ceiling.py)
            from benchmarks.driver_ceiling import ceiling_line, measure

            print(ceiling_line(measure(repeats=1)))

        res = scaling(counts, args.ops_per_worker, params, backend)
        n1, s1 = res[1]
        nw, sw = res[counts[-1]]
        print(f"ratio to linear at {counts[-1]} workers: {nw / sw / (counts[-1] * n1 / s1):.2f} "
              f"(target >= 0.90)")
        if args.ray_data:
            compare_ray_data(params, backend)
    finally:
        ray.shutdown()
        if cluster is not None:
            cluster.stop()


if __name__ == "__main__":
    main()
