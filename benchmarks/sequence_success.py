"""Predicted against re-measured sequence success, and the plan chosen by sequence success against
the one chosen by product (issue 46's validation tables; docs/RESULTS.md, "Plans that hold").

    python benchmarks/sequence_success.py [--quick] [--remeasure 2000] [ASSEMBLY.json ...]

For each assembly: the default plan (``rap-farm plan``'s: the search, 3 candidates, rollouts under
the shipped cell's errors) and the search's best product alone (``--candidates 0``), on one score
cache; then both plans re-measured on independent seeds (another root seed, ``--remeasure``
rollouts, 2,000: +-0.022 at most, so that the check is of the prediction's interval and not of the
re-measurement's own noise; with 400 a perfectly calibrated prediction's re-measurement falls
outside its +-0.05 interval about one time in six). Prints a Markdown table: R, the predicted
sequence success with its 95% interval, the re-measurement, whether it lies inside the interval
and within 0.05, and the product plan's re-measured success (the same plan measured once). Cost:
a few rollout waves per plan and the re-measurements (a minute or two an assembly on 2 cores;
the 22-brick wall about ten).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT = ["cells/stack.json", "cells/side-peg.json", "cells/arch.json", "cells/arch-centring.json",
           "rectilinear.json", "unseen/tangram.json", "unseen/pegs-s103.json",
           "unseen/packing-s100.json", "unseen/wall-s101.json", "unseen/knobs-s101.json",
           "unseen/convex-s102.json", "unseen/funnels-s103.json", "pentagons.json", "hexagon.json",
           "cells/brick-wall-22.json"]
REMEASURE_SEED, REMEASURE = 1_000_003, 2000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--quick", action="store_true", help="the first four assemblies")
    ap.add_argument("--remeasure", type=int, default=REMEASURE,
                    help="rollouts of each re-measurement")
    args = ap.parse_args()
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.execution.sequence import measure
    from rap.io import load_assembly
    from rap.plan import plan
    from rap.plan.execution import ExecutionOptions, rollout_plan
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell
    from rap.sim.params import SimParams

    names = args.assemblies or (DEFAULT[:4] if args.quick else DEFAULT)
    cell = Cell()
    sim = LocalSimulator(processes=2)
    print("| assembly | parts | R | predicted [95%] | re-measured | inside | within 0.05 | "
          "chosen by | product plan re-measured | ratio | seconds (plan with rollouts / without) |")
    print("|---|---:|---:|---|---:|:-:|:-:|---|---:|---:|---|")
    try:
        for name in names:
            path = Path(name) if Path(name).is_file() else ROOT / "assemblies" / name
            if not path.is_file():
                print(f"| {name} | missing |", flush=True)
                continue
            asm = load_assembly(path)
            opts = ExecutionOptions(errors=cell_errors(cell), mm_per_unit=mm_per_unit(cell, asm))
            cache = ScoreCache()
            problem = PlanningProblem(asm, SimParams(), 0)
            t = time.perf_counter()
            bare = plan(problem, simulator=sim, cache=cache)
            t_bare = time.perf_counter() - t
            if not bare.found:
                print(f"| {asm.name} | {len(asm.parts)} | no plan ({bare.status.value}) |",
                      flush=True)
                continue
            t = time.perf_counter()
            chosen = plan(problem, simulator=sim, cache=cache, execution=opts, alternatives=3)
            t_full = time.perf_counter() - t
            product = plan(problem, simulator=sim, cache=cache, execution=opts)
            rplans = [rollout_plan(problem, p, opts) for p in (chosen, product)]
            again = [measure(asm, rplans[0], sim, REMEASURE_SEED,
                             rollouts=args.remeasure).success]
            again.append(again[0] if rplans[1].steps == rplans[0].steps else measure(
                asm, rplans[1], sim, REMEASURE_SEED, rollouts=args.remeasure).success)
            seq = chosen.sequence
            lo, hi = seq.interval
            inside = lo <= again[0].value <= hi
            close = abs(seq.success - again[0].value) <= 0.05
            ratio = again[0].value / again[1].value if again[1].value else float("inf")
            print(f"| {asm.name} | {len(asm.parts)} | {chosen.robustness:.3f} | "
                  f"{seq.success:.3f} [{lo:.3f}, {hi:.3f}] ({seq.rollouts}) | "
                  f"{again[0].value:.3f} | {'yes' if inside else 'NO'} | "
                  f"{'yes' if close else 'NO'} | {seq.chosen_by} | {again[1].value:.3f} "
                  f"(R {product.robustness:.3f}) | {ratio:.2f} | {t_full:.1f} / {t_bare:.1f} |",
                  flush=True)
    finally:
        sim.close()


if __name__ == "__main__":
    main()
