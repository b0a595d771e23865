"""Would labels from perturbed starts pay? Issue 46's "measure whether labels from perturbed starts
help", measured at its ceiling: the simulator's own perturbed-start scores (what a scorer that
learned them perfectly would predict) against the exact-start scores, each planned optimally, each
plan then measured by whole-plan rollouts.

    python -m research.perturbed_starts offsets [--rollouts 200] [ASSEMBLY.json ...]
    python -m research.perturbed_starts plans [--jsonl FILE] [--work DIR] [ASSEMBLY.json ...]

**offsets**: where the earlier steps leave the parts. The default plan (shipped model, root seed 0)
of each calibration assembly (``CALIBRATION``: none of the evaluated ones) is rolled out under the
shipped cell's errors, errors carried; every step that succeeds records where its moving parts came
to rest: the distance off their goal as a fraction of the step's tolerance radius (``pos_tol`` of
the moving extent) and the angle. Written to ``rap/data/rest_offsets.json`` (shipped since the
eighth session: ``rap.execution.perturbed``).

**plans**: per evaluated assembly (``TIGHT``, choice_breadth's eight tight fits), every operation of
the AND/OR graph scored twice, 100 trials each:

* **exact start** (the labels the corpus holds; the simulator's seed, ``problem.seed(op)``);
* **perturbed start**: every fixed part off its place by one draw of the recorded offsets (a
  random direction; the distance scaled to that part's tolerance radius; the angle's sign random),
  the moving body held off by one draw of the cell's error model, and the rollouts' rule of
  success (the body reaches the goal, the parts come to rest within the tolerance after
  ``SETTLE_S`` more under control). Trial t draws from ``SeedSequence(problem.seed(op),
  spawn_key=(t,))`` alone.

Free operations score 1 in both (not simulated, as the scorer's rule). Each set of scores is planned
by the optimal DP (``rap.plan.dp.dp_choice``), and both plans are measured by 400 rollouts on an
independent root seed (1,000,003), under the shipped cell's errors, carried. One JSON line per
assembly and a Markdown table: each plan's product of exact scores (R), its product of perturbed
scores, and its measured sequence success.

Parts placed together move together in a real execution; here each fixed part is drawn on its own,
so the perturbed start is rougher than a rollout's (an upper bound on what perturbation changes).
Cost: two simulations of every operation (about 0.15 s each on a core; 350-1,600 operations an
assembly), then 800 rollouts; 5-25 minutes an assembly on 2 cores. Scores are kept in ``--work``
(default ``/tmp/perturbed_starts``), so a rerun resumes.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TIGHT = ["unseen/wall-s101.json", "unseen/convex-s102.json", "unseen/pegs-s103.json",
         "pentagons.json", "hexagon.json", "unseen/packing-s100.json", "unseen/knobs-s101.json",
         "rectilinear.json"]
CALIBRATION = ["cells/stack.json", "cells/arch.json", "cells/arch-centring.json",
               "cells/side-peg.json", "grid.json", "mixed-square.json", "triangles.json",
               "unseen/basketweave.json", "unseen/c-shapes-s100.json", "unseen/fan-s100.json",
               "unseen/hub-s101.json", "unseen/polyomino-s100.json"]
OFFSETS = ROOT / "rap" / "data" / "rest_offsets.json"  # rap.execution.perturbed.REST_OFFSETS
REMEASURE_SEED, REMEASURE = 1_000_003, 400


def assembly_path(name: str) -> Path:
    return Path(name) if Path(name).is_file() else ROOT / "assemblies" / name


def cell_options(asm):
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.robot.cell import Cell

    cell = Cell()
    return cell_errors(cell), mm_per_unit(cell, asm)


# -- offsets: where the earlier steps leave the parts ---------------------------------------------

def record_offsets(asm, steps, params, errors, mm_per_unit: float, rollouts: int,
                   seed: int = 0) -> list[tuple[float, float]]:
    """``(distance / tolerance radius, angle)`` of every succeeded step's moving parts at rest, over
    ``rollouts`` rollouts of ``steps`` (in this process: ``rap.execution.rollout._carry`` is
    observed)."""
    from rap.execution import rollout
    from rap.sim.placement import placement

    radius = {}
    seen: list[tuple[float, float]] = []
    carry = rollout._carry

    def observe(poses, op, pose):
        key = (op.moving, op.fixed, op.direction)
        if key not in radius:
            radius[key] = params.pos_tol * placement(asm, op, params.start_gap).moving_extent
        (ox, oy), ang = pose[1], pose[2]
        seen.append((math.hypot(ox, oy) / radius[key], (ang + math.pi) % (2 * math.pi) - math.pi))
        carry(poses, op, pose)

    plan = rollout.RolloutPlan(tuple(steps), params, errors, mm_per_unit)
    rollout._carry = observe
    try:
        rollout.run_chunks(asm, plan, seed, rollout.chunks(0, rollouts))
    finally:
        rollout._carry = carry
    return seen


def offsets_command(names: list[str], rollouts: int) -> None:
    from rap.io import load_assembly
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan import plan
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.sim.params import SimParams

    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    sim = LocalSimulator(processes=2)
    rows, per = [], {}
    try:
        for name in names:
            asm = load_assembly(assembly_path(name))
            problem = PlanningProblem(asm, SimParams(), 0)
            found = plan(problem, model=model, simulator=sim, cache=ScoreCache())
            errors, mmu = cell_options(asm)
            got = record_offsets(asm, [s.to_operation() for s in found.steps], problem.params,
                                 errors, mmu, rollouts)
            per[asm.name] = len(got)
            rows += got
            r = np.array([g[0] for g in got])
            print(f"{asm.name}: {len(got)} steps at rest, distance/tolerance median "
                  f"{np.median(r):.3f}, 90% {np.quantile(r, 0.9):.3f}", flush=True)
    finally:
        sim.close()
    OFFSETS.write_text(json.dumps({"rollouts": rollouts, "assemblies": per,
                                   "offsets": [[round(a, 5), round(b, 6)] for a, b in rows]}))
    print(f"{len(rows)} offsets -> {OFFSETS.relative_to(ROOT)}")


# -- perturbed-start scores ------------------------------------------------------------------------

def perturbed_score(asm, op, params, errors, mm_per_unit: float, offsets: np.ndarray,
                    seed: int) -> int:
    """Successes of ``params.trials`` perturbed-start trials of ``op``
    (``rap.execution.perturbed.perturbed_successes``, its home since the eighth session)."""
    from rap.execution.perturbed import perturbed_successes

    return perturbed_successes(asm, op, params, errors, mm_per_unit, seed, offsets)


def perturbed_task(args):  # a worker process
    return perturbed_score(*args)


# -- plans: each set of scores planned optimally, both plans measured ------------------------------

def cached_scores(problem, ops, work: Path, tag: str, run) -> dict[str, float]:
    """``{key: score}`` of ``ops`` (free ones 1), those missing from ``work/<assembly>.<tag>.json``
    computed by ``run(missing ops) -> successes`` and written there (a rerun resumes)."""
    path = work / f"{problem.assembly.name}.{problem.root_seed}.{tag}.json"
    known = json.loads(path.read_text()) if path.exists() else {}
    missing = {}
    for op in ops:
        k = problem.key(op)
        if k not in known and not problem.is_free(op):
            missing.setdefault(k, op)
    if missing:
        wins = run(list(missing.values()))
        known.update({k: w / problem.params.trials for k, w in zip(missing, wins)})
        path.write_text(json.dumps(known))
    return {problem.key(op): 1.0 if problem.is_free(op) else known[problem.key(op)] for op in ops}


def best_sequence(problem, graph, score: dict[str, float]) -> tuple[float, tuple]:
    """The optimal DP's product and sequence (operations in assembly order) under ``score``."""
    from rap.plan.dp import dp_choice, dp_tree
    from rap.plan.graph import assembly_order
    from rap.plan.report.result import PlanStep

    whole = problem.whole
    score_of = {s: [score[problem.key(op)] for op in c] for s, c in graph.items()}
    best, arg = dp_choice(graph, score_of)
    choice = {sub: PlanStep.of(op, "sim", score=score_of[sub][i])
              for sub, (i, op) in dp_tree(graph, arg, whole).items()}
    return best[whole], tuple(s.to_operation() for s in assembly_order(choice, whole))


def evaluate(path: Path, pool, sim, offsets: np.ndarray, work: Path, seed: int = 0) -> dict:
    from rap.execution.rollout import RolloutPlan, chunks
    from rap.execution.sequence import tally
    from rap.io import load_assembly
    from rap.plan.graph import reachable
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    t0 = time.perf_counter()
    asm = load_assembly(path)
    problem = PlanningProblem(asm, SimParams(), seed)
    errors, mmu = cell_options(asm)
    graph = reachable(problem)
    ops = [op for c in graph.values() for op in c]
    exact = cached_scores(problem, ops, work, "exact", lambda miss: [
        c.successes for c in sim.simulate_many(problem, miss)])
    pert = cached_scores(problem, ops, work, "perturbed", lambda miss: list(pool.map(
        perturbed_task, [(asm, op, problem.params, errors, mmu, offsets, problem.seed(op))
                          for op in miss], chunksize=4)))
    t_scores = time.perf_counter() - t0
    plans = {"exact": best_sequence(problem, graph, exact),
             "perturbed": best_sequence(problem, graph, pert)}
    row = {"assembly": asm.name, "parts": len(asm.parts), "seed": seed, "operations": len(ops),
           "same_plan": plans["exact"][1] == plans["perturbed"][1],
           "mean_exact": float(np.mean(list(exact.values()))),
           "mean_perturbed": float(np.mean(list(pert.values())))}
    for name, (_, seq) in plans.items():
        rplan = RolloutPlan(seq, problem.params, errors, mmu)
        wins, _, _, runs = tally(len(seq), sim.run_rollouts(asm, rplan, REMEASURE_SEED,
                                                            chunks(0, REMEASURE)))
        row[name] = {"R": math.prod(exact[problem.key(op)] for op in seq),
                     "R_perturbed": math.prod(pert[problem.key(op)] for op in seq),
                     "measured": wins / runs, "successes": wins, "rollouts": runs}
    row["ratio"] = (round(row["perturbed"]["measured"] / row["exact"]["measured"], 3)
                    if row["exact"]["measured"] else None)
    row["seconds"] = {"scores": round(t_scores, 1), "all": round(time.perf_counter() - t0, 1)}
    return row


def plans_command(names: list[str], jsonl: Path | None, work: Path, seed: int = 0) -> None:
    from concurrent.futures import ProcessPoolExecutor

    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.stats import rate

    offsets = np.array(json.loads(OFFSETS.read_text())["offsets"], dtype=float)
    work.mkdir(parents=True, exist_ok=True)
    sim = LocalSimulator(processes=2)
    rows = []
    try:
        with ProcessPoolExecutor(2) as pool:
            for name in names:
                row = evaluate(assembly_path(name), pool, sim, offsets, work, seed)
                rows.append(row)
                print(json.dumps(row), flush=True)
                if jsonl:
                    with jsonl.open("a") as f:
                        f.write(json.dumps(row) + "\n")
    finally:
        sim.close()

    def cell(e):
        r = rate(e["successes"], e["rollouts"])
        return (f"{e['R']:.3f} | {e['R_perturbed']:.3f} | {e['measured']:.3f} "
                f"[{r.low:.3f}, {r.high:.3f}]")

    print("\n| assembly | parts | operations | mean score: exact, perturbed | exact-start plan: R "
          "| its perturbed product | measured [95%] | perturbed-start plan: R | its perturbed "
          "product | measured [95%] | ratio |")
    print("|---|---:|---:|---|---:|---:|---|---:|---:|---|---:|")
    for r in rows:
        same = " (same plan)" if r["same_plan"] else ""
        print(f"| {r['assembly']} | {r['parts']} | {r['operations']} | {r['mean_exact']:.3f}, "
              f"{r['mean_perturbed']:.3f} | {cell(r['exact'])} | {cell(r['perturbed'])} | "
              f"{r['ratio']}{same} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("command", choices=("offsets", "plans"))
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--rollouts", type=int, default=200, help="offsets: rollouts an assembly")
    ap.add_argument("--jsonl", type=Path)
    ap.add_argument("--work", type=Path, default=Path("/tmp/perturbed_starts"))
    ap.add_argument("--seed", type=int, default=0, help="plans: the root seed of both scores")
    args = ap.parse_args()
    if args.command == "offsets":
        offsets_command(args.assemblies or CALIBRATION, args.rollouts)
    else:
        plans_command(args.assemblies or TIGHT, args.jsonl, args.work, args.seed)


if __name__ == "__main__":
    main()
