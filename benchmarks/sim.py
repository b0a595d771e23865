"""Benchmark of the robustness simulator against the Chipmunk floor, on the same scenes.

For each operation: seconds per operation of ``simulate`` (scene build + trials), microseconds per
body-step of the shipped control loop (``us/bs``), and the floor measured in the same run:

* ``floor``: a fresh copy of the same scene replayed with the commands the shipped loop applied
  (logged at every control step) and the same removals of decided trials at the same steps: the
  same Chipmunk calls (set forces + step) on the same states, with no controller at all. It is
  what any controller driving this space through pymunk's C API must pay at least.
  ``ratio`` = shipped / floor (target <= 1.3).

Operations: the fixtures of tests/sim/fixtures.py, plus every online partition of the whole of
each assemblies/*.json. The last line is ``ratio to the Chipmunk floor: X.XX`` over the total.

    python benchmarks/sim.py [--trials 100] [--seed 1] [--limit N] [--fixtures-only]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.sim import kernel  # noqa: E402
from rap.sim.params import SimParams  # noqa: E402
from rap.sim.simulator import build_scene, remove_trial, run_trials, simulate  # noqa: E402


def fixture_cases():
    spec = importlib.util.spec_from_file_location("rap_sim_fixtures", ROOT / "tests/sim/fixtures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return [(f"fixture:{name}", a, o) for name, (a, o) in mod.CASES.items()]


def assembly_cases(limit: int | None):
    from rap.io import load_assembly
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.partitions import online_partitions

    out = []
    for path in sorted((ROOT / "assemblies").glob("*.json")):
        a = load_assembly(path)
        parts = online_partitions(build_ndbg(a), frozenset(a.ids))
        for k, part in enumerate(parts[:limit] if limit else parts):
            out.append((f"{a.name}:{k}", a, part.operation()))
    return out


def replay_floor(assembly, operation, params, log, schedule, steps: int) -> float:
    """Seconds to replay the logged commands on a fresh scene, with the same removals."""
    scene = build_scene(assembly, operation, params)
    n = len(scene.movers)
    api = kernel.ChipmunkApi(scene.space, n + 1)
    k_sub, dt = params.control_substeps, params.dt_s
    removals = {step // k_sub: gone for step, gone in schedule}
    points = sorted(c for c in removals if c < steps) + [steps]
    t0 = time.perf_counter()
    c = 0
    for stop in points:
        kernel.replay_steps(api.ptrs, api.snum, api.sarr, log, c, stop, k_sub, dt)
        c = stop
        for t in removals.get(stop, ()):
            remove_trial(scene, t)
    return time.perf_counter() - t0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--limit", type=int, default=None, help="partitions per assembly")
    ap.add_argument("--fixtures-only", action="store_true")
    args = ap.parse_args(argv)
    params = SimParams(trials=args.trials)
    cases = fixture_cases() + ([] if args.fixtures_only else assembly_cases(args.limit))
    a0, o0 = cases[0][1], cases[0][2]
    t0 = time.perf_counter()
    warm = params.with_(trials=2)  # compile or load the compiled loops before timing anything
    log = np.zeros((warm.steps // warm.control_substeps, 3, 3))
    info = run_trials(build_scene(a0, o0, warm), warm, np.random.default_rng(0), log=log)
    replay_floor(a0, o0, warm, log, info.schedule, info.steps_run // warm.control_substeps)
    print(f"simulator benchmark: {len(cases)} operations, {params.trials} trials, "
          f"dt {params.dt_s:.5f} s x {params.control_substeps} per control step, "
          f"params {params.fingerprint()}; kernel ready in {time.perf_counter() - t0:.2f} s")
    head = (f"{'operation':28s} {'score':>5s} {'shapes':>6s} {'s/op':>7s} {'body-steps':>10s} "
            f"{'us/bs':>6s} {'floor':>6s} {'ratio':>5s}")
    print(head)
    print("-" * len(head))
    tot_ship = tot_floor = tot_bs = tot_op = 0.0
    scores = []
    n_ctrl = params.steps // params.control_substeps
    for name, a, o in cases:
        t0 = time.perf_counter()
        res = simulate(a, o, params, np.random.default_rng(args.seed))
        t_op = time.perf_counter() - t0
        # the control loop alone, on a fresh scene with the same seed (build excluded)
        scene = build_scene(a, o, params)
        n_shapes = len(scene.moving_shapes[0]) + len(scene.fixed_shapes[0])
        t1 = time.perf_counter()
        info = run_trials(scene, params, np.random.default_rng(args.seed))
        t_ship = time.perf_counter() - t1
        # the same run again, logging the commands, then their replay: the floor
        log = np.zeros((n_ctrl, params.trials + 1, 3))
        info2 = run_trials(build_scene(a, o, params), params, np.random.default_rng(args.seed), log=log)
        assert info2.body_steps == info.body_steps and info2.schedule == info.schedule
        t_floor = replay_floor(a, o, params, log, info.schedule, info.steps_run // params.control_substeps)
        bs = info.body_steps
        print(f"{name[:28]:28s} {res.score:5.2f} {n_shapes:6d} {t_op:7.3f} {bs:10d} "
              f"{1e6 * t_ship / bs:6.2f} {1e6 * t_floor / bs:6.2f} {t_ship / t_floor:5.2f}")
        tot_ship += t_ship
        tot_floor += t_floor
        tot_bs += bs
        tot_op += t_op
        scores.append(res.score)
    print("-" * len(head))
    print(f"{'total':28s} {np.mean(scores):5.2f} {'':6s} {tot_op / len(cases):7.3f} {int(tot_bs):10d} "
          f"{1e6 * tot_ship / tot_bs:6.2f} {1e6 * tot_floor / tot_bs:6.2f} {tot_ship / tot_floor:5.2f}")
    hist, edges = np.histogram(scores, bins=10, range=(0, 1))
    print("score histogram: " + " ".join(f"[{edges[i]:.1f},{edges[i + 1]:.1f}{']' if i == 9 else ')'}:{h}"
                                          for i, h in enumerate(hist)))
    print(f"ratio to the Chipmunk floor: {tot_ship / tot_floor:.2f}")


if __name__ == "__main__":
    main()
