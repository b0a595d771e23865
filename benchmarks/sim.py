"""Benchmark of the robustness simulator against the raw Chipmunk floor, on the same scenes.

For each operation: seconds per operation of ``simulate`` (scene build + trials), microseconds per
body-step of the shipped controller loop (``us/bs``), and two floors measured in the same run:

* ``step``: the time spent inside pymunk (setting forces + ``Space.step``) during that same loop,
  i.e. the same space in exactly the same states; ``ratio`` = shipped / step (target <= 1.3);
* ``coast``: a fresh copy of the same space (same trials, shapes and removal schedule of decided
  trials) stepped with no controller at all, the moving bodies launched toward the goal at the
  carrot speed; ``r.coast`` = shipped / coast. Contacts differ from the controlled run (coasting
  bodies stop at the first obstacle), so this one is noisier.

Operations: the fixtures of tests/sim/fixtures.py, plus every online partition of the whole of
each assemblies/*.json when rap.geometry provides build_ndbg and online_partitions.

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

from rap.sim.params import SimParams  # noqa: E402
from rap.sim.simulator import build_scene, run_trials, simulate  # noqa: E402


def fixture_cases():
    spec = importlib.util.spec_from_file_location("rap_sim_fixtures", ROOT / "tests/sim/fixtures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return [(f"fixture:{name}", a, o) for name, (a, o) in mod.CASES.items()]


def assembly_cases(limit: int | None):
    try:
        from rap.assembly import load_assembly
        from rap.geometry.ndbg import build_ndbg
        from rap.geometry.partitions import online_partitions
    except ImportError as exc:
        print(f"(assemblies skipped: {exc})")
        return []
    out = []
    for path in sorted((ROOT / "assemblies").glob("*.json")):
        a = load_assembly(path)
        parts = online_partitions(build_ndbg(a), frozenset(a.ids))
        for k, part in enumerate(parts[:limit] if limit else parts):
            out.append((f"{a.name}:{k}", a, part.operation()))
    return out


def floor(assembly, operation, params, info) -> float:
    """Seconds to step the same scene with no controller, following the same removal schedule."""
    scene = build_scene(assembly, operation, params)
    for body in scene.movers:
        body.velocity = tuple(params.carrot_speed * scene.direction)
    removals = dict(info.schedule)
    space, dt = scene.space, params.dt_s
    t0 = time.perf_counter()
    for step in range(info.steps_run):
        gone = removals.get(step)
        if gone:
            for t in gone:
                mv, fx = scene.movers[t], scene.statics[t]
                space.remove(mv, *mv.shapes, fx, *fx.shapes)
        space.step(dt)
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
    print(f"simulator benchmark: {len(cases)} operations, {params.trials} trials, "
          f"dt {params.dt_s:.5f} s x {params.control_substeps} per control step, "
          f"params {params.fingerprint()}")
    head = (f"{'operation':28s} {'score':>5s} {'shapes':>6s} {'s/op':>7s} {'body-steps':>10s} "
            f"{'us/bs':>6s} {'step':>6s} {'ratio':>5s} {'coast':>6s} {'r.coast':>7s}")
    print(head)
    print("-" * len(head))
    tot_ship = tot_step = tot_floor = tot_bs = tot_op = 0.0
    scores = []
    for name, a, o in cases:
        rng = np.random.default_rng(args.seed)
        t0 = time.perf_counter()
        res = simulate(a, o, params, rng)
        t_op = time.perf_counter() - t0
        # the controller loop alone, on a fresh scene with the same seed (build excluded)
        scene = build_scene(a, o, params)
        n_shapes = len(scene.movers[0].shapes) + len(scene.statics[0].shapes)
        t1 = time.perf_counter()
        info = run_trials(scene, params, np.random.default_rng(args.seed), clock=True)
        t_ship = time.perf_counter() - t1
        t_step = info.physics_s
        t_floor = floor(a, o, params, info)
        bs = info.body_steps
        print(f"{name[:28]:28s} {res.score:5.2f} {n_shapes:6d} {t_op:7.3f} {bs:10d} "
              f"{1e6 * t_ship / bs:6.2f} {1e6 * t_step / bs:6.2f} {t_ship / t_step:5.2f} "
              f"{1e6 * t_floor / bs:6.2f} {t_ship / t_floor:7.2f}")
        tot_ship += t_ship
        tot_step += t_step
        tot_floor += t_floor
        tot_bs += bs
        tot_op += t_op
        scores.append(res.score)
    print("-" * len(head))
    print(f"{'total':28s} {np.mean(scores):5.2f} {'':6s} {tot_op / len(cases):7.3f} {int(tot_bs):10d} "
          f"{1e6 * tot_ship / tot_bs:6.2f} {1e6 * tot_step / tot_bs:6.2f} {tot_ship / tot_step:5.2f} "
          f"{1e6 * tot_floor / tot_bs:6.2f} {tot_ship / tot_floor:7.2f}")
    hist, edges = np.histogram(scores, bins=10, range=(0, 1))
    print("score histogram: " + " ".join(f"[{edges[i]:.1f},{edges[i + 1]:.1f}{']' if i == 9 else ')'}:{h}"
                                          for i, h in enumerate(hist)))


if __name__ == "__main__":
    main()
