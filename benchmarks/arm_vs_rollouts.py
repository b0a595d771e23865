"""The simulated arm against the planar rollouts' prediction, both under the shipped cell's errors
(issue 46's "the arm with default errors"; docs/ROBOT.md, "Errors and rollouts").

    python benchmarks/arm_vs_rollouts.py [--runs 50] [--only NAME ...] [--case NAME=PLAN:ASSEMBLY ...]

For each robot plan of tests/robot/data (the stack, the tangram, the 22-brick wall; ``--only``
some of them), and each ``--case`` (a plan file of ``rap-farm plan`` and its assembly): the planar
sequence success predicted by rollouts (``rap.execution``, waves to +-0.05) with the scores' force
noise (the cell's default) and without it (``[errors] force_noise = false``: a stiff
position-controlled arm, position errors only), and the success of ``--runs`` executions on the
Panda in pybullet (``rap.robot.arm_sim``) with the cell's errors, each with its 95% interval. Prints a Markdown table. Cost: the rollouts (seconds) and 0.2-2 s an
arm run.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = [("stack", "assemblies/cells/stack.json"), ("tangram", "assemblies/unseen/tangram.json"),
         ("brick-wall-22", "assemblies/cells/brick-wall-22.json")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--only", nargs="*", help="of the shipped robot plans, only these")
    ap.add_argument("--case", action="append", default=[], metavar="NAME=PLAN:ASSEMBLY",
                    help="one more plan (a rap-farm plan file) and its assembly")
    args = ap.parse_args()
    cases = [(n, ROOT / "tests/robot/data" / f"{n}.plan.json", ROOT / a) for n, a in CASES
             if args.only is None or n in args.only]
    for spec in args.case:
        name, _, paths = spec.partition("=")
        plan_path, _, asm_path = paths.partition(":")
        if not (name and plan_path and asm_path):
            ap.error(f"--case {spec!r}: expected NAME=PLAN:ASSEMBLY")
        cases.append((name, Path(plan_path), Path(asm_path)))
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.arm_sim import DEFAULT_ARM_SIM, run_arm
    from rap.robot.cell import Cell
    from rap.robot.inputs import load_plan_and_assembly
    from rap.robot.planar import run_planar
    from rap.robot.program import build_program

    cell = Cell()
    errors = cell_errors(cell)
    sim = LocalSimulator(processes=2)
    print("| plan | steps | R | rollouts, force noise | rollouts, position errors only | "
          "arm executed | arm - position-only |")
    print("|---|---:|---:|---|---|---|---:|")
    lost = []
    try:
        for name, plan_path, asm_path in cases:
            plan, _, asm = load_plan_and_assembly(plan_path, asm_path)
            pred, stiff = (run_planar(plan, asm, trials=None, seed=0, errors=e,
                                      mm_per_unit=mm_per_unit(cell, asm), runner=sim).success
                           for e in (errors, replace(errors, force_noise=False)))
            ran = run_arm(build_program(plan, asm, cell), asm, trials=args.runs, seed=0,
                          params=replace(DEFAULT_ARM_SIM, errors=errors))
            arm = ran.success
            print(f"| {name} | {len(plan.steps)} | {plan.robustness:.3f} | {pred.text()} | "
                  f"{stiff.text()} | {arm.text()} | {arm.value - stiff.value:+.3f} |", flush=True)
            if abs(arm.value - stiff.value) > 0.1:
                lost.append((name, plan, ran.steps))
    finally:
        sim.close()
    for name, plan, steps in lost:  # where the arm fails and the planar rollouts do not
        print(f"\n{name}: the steps at which arm runs went wrong (reached, inserted, jammed, the "
              f"arm touching a placed part, a placed part off its goal after the step)")
        for k, (step, c) in enumerate(zip(plan.steps, steps)):
            if c.reached != c.inserted or c.jammed or c.arm_contacts or c.displaced:
                print(f"  step {k + 1} ({', '.join(sorted(step.moving))}): {c.reached}, "
                      f"{c.inserted}, {c.jammed}, {c.arm_contacts}, {c.displaced}")


if __name__ == "__main__":
    main()
