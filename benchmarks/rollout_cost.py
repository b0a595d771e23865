"""What the rollouts add to the default plan's time, and where it goes (issue 46's cost target: the
default plan, rollouts included, in at most 2x the plan without them; docs/RESULTS.md, "Plans that
hold when executed").

    python benchmarks/rollout_cost.py [--repeats 3] [ASSEMBLY.json ...]

Per assembly, ``--repeats`` alternated pairs, each on a fresh score cache and 2 worker processes,
the shipped model loaded once: the default plan without rollouts (``rap-farm plan
--no-rollouts``'s) and with them (the search's plan and 3 candidates chosen by rollouts under the
shipped cell's errors, the chosen plan measured to +-0.05, its steps' tolerances). The least time
of each, their ratio, and the rollout time split: the choice (rollouts of the candidates beyond the
reported figure's), the measurement (the rollouts the figure counts) and the tolerances, each as a
share of the plan without rollouts. Cost: about 2 x repeats plans an assembly (seconds each).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT = ["unseen/packing-s100.json", "rectilinear.json", "hexagon.json",
           "unseen/funnels-s103.json", "unseen/tangram.json", "unseen/wall-s101.json"]


class TimedRunner:
    """A rollout and tolerance runner that times what it runs on another one."""

    def __init__(self, inner):
        self.inner, self.rollout_s, self.tolerance_s, self.rollouts = inner, 0.0, 0.0, 0

    def run_rollouts(self, assembly, plan, root_seed, work):
        t = time.perf_counter()
        out = self.inner.run_rollouts(assembly, plan, root_seed, work)
        self.rollout_s += time.perf_counter() - t
        self.rollouts += sum(c for _, c in work)
        return out

    def run_tolerances(self, jobs):
        t = time.perf_counter()
        out = self.inner.run_tolerances(jobs)
        self.tolerance_s += time.perf_counter() - t
        return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.io import load_assembly
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan import plan
    from rap.plan.execution import ExecutionOptions
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell

    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    cell = Cell()
    sim = LocalSimulator(processes=2, prestart=True)
    print("| assembly | parts | plan s | with rollouts s | ratio | rollouts (figure + choice) | "
          "choice / plan | measurement / plan | tolerances / plan |")
    print("|---|---:|---:|---:|---:|---|---:|---:|---:|")
    try:
        for name in args.assemblies or DEFAULT:
            path = Path(name) if Path(name).is_file() else ROOT / "assemblies" / name
            asm = load_assembly(path)
            opts = ExecutionOptions(errors=cell_errors(cell), mm_per_unit=mm_per_unit(cell, asm))
            bare, full, best = [], [], None
            for _ in range(args.repeats):
                t = time.perf_counter()
                plan(asm, model=model, simulator=sim, cache=ScoreCache())
                bare.append(time.perf_counter() - t)
                runner = TimedRunner(sim)
                t = time.perf_counter()
                got = plan(asm, model=model, simulator=sim, cache=ScoreCache(), execution=opts,
                           rollouts=runner, alternatives=3)
                full.append(time.perf_counter() - t)
                if full[-1] == min(full):
                    best = (runner, got.sequence.rollouts)
            runner, figure = best
            b = min(bare)
            # the figure's rollouts, timed at the rollouts' mean rate: the rest is the choice's
            measure_s = runner.rollout_s * figure / max(1, runner.rollouts)
            print(f"| {asm.name} | {len(asm.parts)} | {b:.2f} | {min(full):.2f} | "
                  f"{min(full) / b:.2f} | {figure} + {runner.rollouts - figure} | "
                  f"{(runner.rollout_s - measure_s) / b:.2f} | {measure_s / b:.2f} | "
                  f"{runner.tolerance_s / b:.2f} |", flush=True)
    finally:
        sim.close()


if __name__ == "__main__":
    main()
