"""Rollouts of several plans in one chunk, the steps their prefixes share simulated once: measured,
does not pay (issue 46's choice cost; research/README.md, "Measured, not kept").

    python -m research.variants.shared_prefix [ASSEMBLY.json ...]

While the default plan chooses among the search's best plans (``rap.plan.execution.choose``), it
runs the same rollout indices of every candidate (common random numbers). Rollout ``i``'s step
``k`` draws from ``(root seed, i, k)`` alone, so where two plans begin with the same steps, a
chunk's live rollouts, their parts' poses and the scenes are the same in both up to the first step
that differs: ``run_chunk_shared`` walks the plans' prefix tree and simulates each shared step
once, branching the chunk's state where the plans part. Its outcomes are those of
``rap.execution.rollout.run_chunk`` on each plan, bit for bit (``main`` checks it on every chunk).

``main``: the default plan's candidates (``--candidates``, 3) on each assembly, four chunks (100
rollouts) of each, CPU seconds of ``run_chunk`` per plan against ``run_chunk_shared`` (the least
of ``--repeats`` alternated runs, 3). Cost: six times the choice's first wave an assembly (a
minute).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from rap.assembly import Assembly
from rap.execution import rollout as ro
from rap.sim.layouts import TrialLayout
from rap.sim.simulator import build_scene, run_trials

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = ["rectilinear.json", "hexagon.json", "unseen/packing-s100.json",
           "unseen/funnels-s103.json"]


def _advance(assembly, plan, params, settle, free: bool, k: int, root_seed: int, first: int,
             state) -> tuple:
    """Step ``k`` of ``plan`` on ``state`` = (poses, failed, alive) of a chunk, as
    ``run_chunk`` takes it; the state after it."""
    poses, failed, alive = state
    op = plan.steps[k]
    rngs = [ro.step_rng(root_seed, first + j, k) for j in alive]
    grasps = [plan.errors.offsets(r, op.direction, plan.mm_per_unit) for r in rngs]
    if free:
        pivot, radius = ro._free_landing(assembly, op, params)
        landed = [ro._landed(pivot, g) for g in grasps]
        ok = [ro.within_tolerance(pose, None, params, radius) for pose in landed]
    else:
        layouts = [TrialLayout({p: poses[j][p] for p in op.moving | op.fixed if p in poses[j]}, g)
                   for j, g in zip(alive, grasps)]
        scene = build_scene(assembly, op, params, layouts=layouts)
        info = run_trials(scene, params, None, record=len(alive), trial_rngs=rngs,
                          settle_steps=settle)
        rec = info.recording[0]
        landed = [ro.part_pose(rec[t][~np.isnan(rec[t][:, 0])][-1], scene, grasps[t])
                  if info.outcome[t] == 1 else None for t in range(len(alive))]
        ok = [pose is not None and ro.within_tolerance(pose, scene, params) for pose in landed]
    survivors = []
    for j, pose, good in zip(alive, landed, ok):
        if not good:
            failed[j] = k
            continue
        survivors.append(j)
        if plan.carry:
            ro._carry(poses[j], op, pose)
    return poses, failed, survivors


def run_chunk_shared(assembly: Assembly, plans: Sequence[ro.RolloutPlan], root_seed: int,
                     first: int, count: int) -> tuple[list[ro.ChunkOutcome], int]:
    """(each plan's ``ChunkOutcome`` of rollouts ``first .. first + count - 1``, the steps
    simulated or landed); the plans share their parameters, errors and ``carry``."""
    t0 = time.perf_counter()
    params = plans[0].params if plans[0].errors.force_noise else replace(plans[0].params, eta=0.0)
    settle = max(1, int(round(ro.SETTLE_S / (params.dt_s * params.control_substeps))))
    free = [ro._free_steps(assembly, p.steps) for p in plans]
    failed_at: list[tuple | None] = [None] * len(plans)
    steps = 0

    def walk(group: list[int], k: int, state) -> None:
        nonlocal steps
        branches: dict = {}
        for g in group:
            if k >= len(plans[g].steps) or not state[2]:
                failed_at[g] = tuple(state[1])
            else:
                branches.setdefault(plans[g].steps[k], []).append(g)
        for n, members in enumerate(branches.values()):
            last = n == len(branches) - 1
            mine = state if last else ([dict(d) for d in state[0]], list(state[1]), list(state[2]))
            steps += 1
            walk(members, k + 1, _advance(assembly, plans[members[0]], params, settle,
                                          free[members[0]][k], k, root_seed, first, mine))

    walk(list(range(len(plans))), 0, ([{} for _ in range(count)], [-1] * count, list(range(count))))
    seconds = (time.perf_counter() - t0) / len(plans)
    return [ro.ChunkOutcome(first, failed_at[i], seconds) for i in range(len(plans))], steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--candidates", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    import rap.plan.execution as ex
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.io import load_assembly
    from rap.plan import plan
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell
    from rap.sim.params import SimParams

    seen = {}
    choose = ex.choose

    def spy(problem, plans, runner, options, seed, *a, **kw):  # the candidates the plan chose among
        seen["plans"] = [ex.rollout_plan(problem, p, options) for p in plans], seed
        return choose(problem, plans, runner, options, seed, *a, **kw)

    ex.choose = spy
    sim = LocalSimulator(processes=1)
    print("| assembly | parts | plans | steps shared with the search's plan | steps: each plan "
          "/ shared | CPU s: each plan / shared | ratio |")
    print("|---|---:|---:|---|---|---|---:|")
    try:
        for name in args.assemblies or DEFAULT:
            path = Path(name) if Path(name).is_file() else ROOT / "assemblies" / name
            asm, cell = load_assembly(path), Cell()
            opts = ex.ExecutionOptions(errors=cell_errors(cell), mm_per_unit=mm_per_unit(cell, asm))
            plan(PlanningProblem(asm, SimParams(), 0), simulator=sim, cache=ScoreCache(),
                 execution=opts, alternatives=args.candidates, rollouts=ex.InProcess())
            rplans, seed = seen.pop("plans")
            head = rplans[0].steps
            shared = [next((k for k, (a, b) in enumerate(zip(p.steps, head)) if a != b),
                           min(len(p.steps), len(head))) for p in rplans[1:]]
            work = ro.chunks(0, 100)
            cpu_each, cpu_together = [], []
            for _ in range(args.repeats):  # alternated; the least CPU of each kept
                c0 = time.process_time()
                each = [[ro.run_chunk(asm, p, seed, f, c) for f, c in work] for p in rplans]
                c1 = time.process_time()
                together = [run_chunk_shared(asm, rplans, seed, f, c) for f, c in work]
                cpu_each.append(c1 - c0)
                cpu_together.append(time.process_time() - c1)
                assert all(each[i][w].failed_at == together[w][0][i].failed_at
                           for i in range(len(rplans)) for w in range(len(work))), "not identical"
            a, b = min(cpu_each), min(cpu_together)
            print(f"| {asm.name} | {len(asm.parts)} | {len(rplans)} | {shared} | "
                  f"{sum(len(p.steps) for p in rplans)} / {together[0][1]} | "
                  f"{a:.2f} / {b:.2f} | {a / b:.2f} |", flush=True)
    finally:
        sim.close()


if __name__ == "__main__":
    main()
