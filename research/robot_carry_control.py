"""Is R's over-prediction of whole-plan success the carried displacement? A control.

For each plan given (``PLAN.json=ASSEMBLY.json``), runs the planar sequence
(``rap.robot.planar.run_planar``) twice with the same seeds: with the parts carried where the
earlier steps left them (``rap-farm execute --planar``), and with every step starting from the
exact placements (``carry=False``), as R assumes. If the exact-start rate agrees with R and the
carried one does not, the gap is the carried displacement, not a difference between these
single-trial runs and the 100-trial scores. Prints one row a plan: R and its interval, both
rates with their 95% Clopper-Pearson intervals (docs/ROBOT.md, "R against what happens").

    python -m research.robot_carry_control PLAN.json=ASSEMBLY.json ... [--trials 200] [--seed 0]
"""

from __future__ import annotations

import argparse

from rap.robot.inputs import load_plan_and_assembly
from rap.robot.planar import run_planar


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="PLAN.json=ASSEMBLY.json")
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"{'plan':<28} {'R':>22}  {'carried':>26}  {'exact starts':>26}")
    for pair in args.pairs:
        plan_path, asm_path = pair.split("=", 1)
        plan, _doc, asm = load_plan_and_assembly(plan_path, asm_path)
        lo, hi = plan.robustness_interval or (float("nan"), float("nan"))
        carried = run_planar(plan, asm, trials=args.trials, seed=args.seed)
        exact = run_planar(plan, asm, trials=args.trials, seed=args.seed, carry=False)
        print(f"{plan.assembly[:28]:<28} {plan.robustness:.3f} [{lo:.3f}, {hi:.3f}]  "
              f"{carried.success.text():>26}  {exact.success.text():>26}", flush=True)


if __name__ == "__main__":
    main()
