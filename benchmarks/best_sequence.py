"""Small assemblies: the default's chosen plan against the best of all their sequences, by rollouts
(issue 46's exhaustive table; docs/RESULTS.md, "Plans that hold").

    python benchmarks/best_sequence.py [ASSEMBLY.json ...]

Every complete plan of the search's AND/OR graph (``SearchPlanner.search`` with a large
``alternatives``: the K-best trees, all of them on a small assembly) is measured by 400 rollouts
under the shipped cell's errors on one seed; the default plan (3 candidates) is measured on the
same seed. Prints the number of sequences, the best one's success, the default's, and the gap.
Cost: 400 rollouts a sequence.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT = ["cells/stack.json", "cells/side-peg.json", "cells/arch.json", "cells/arch-centring.json"]
SEED, ROLLOUTS = 2_000_003, 400


def main() -> None:
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.execution.sequence import measure
    from rap.io import load_assembly
    from rap.plan import plan
    from rap.plan.execution import ExecutionOptions, rollout_plan
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.scoring.scorer import Scorer
    from rap.plan.search.planner import SearchPlanner
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.robot.cell import Cell
    from rap.seeds import DEFAULT_ROOT_SEED
    from rap.sim.params import SimParams

    cell = Cell()
    sim = LocalSimulator(processes=2)
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    print("| assembly | sequences | best of all (R) | default chose (R) | product's best (R) | "
          "default - best |")
    print("|---|---:|---|---|---|---:|")
    try:
        for name in sys.argv[1:] or DEFAULT:
            path = Path(name) if Path(name).is_file() else ROOT / "assemblies" / name
            asm = load_assembly(path)
            opts = ExecutionOptions(errors=cell_errors(cell), mm_per_unit=mm_per_unit(cell, asm),
                                    tolerances=False)
            problem = PlanningProblem(asm, SimParams(), DEFAULT_ROOT_SEED)
            cache = ScoreCache()
            outcome = SearchPlanner(alternatives=10_000).search(
                problem, Scorer(sim, model, cache))
            every = [outcome.plan, *outcome.alternatives]
            chosen = plan(problem, simulator=sim, cache=cache, model=model, execution=opts,
                          alternatives=3)

            def rate(p):
                return measure(asm, rollout_plan(problem, p, opts), sim, SEED,
                               rollouts=ROLLOUTS).success

            rates = [rate(p) for p in every]
            best = max(range(len(every)), key=lambda i: rates[i].value)
            mine = rate(chosen)
            r = every[best].robustness
            print(f"| {asm.name} | {len(every)} | {rates[best].text()} "
                  f"({'?' if r is None else f'{r:.3f}'}) | {mine.text()} "
                  f"({chosen.robustness:.3f}) | {rates[0].text()} ({outcome.plan.robustness:.3f}) "
                  f"| {mine.value - rates[best].value:+.3f} |", flush=True)
    finally:
        sim.close()


if __name__ == "__main__":
    main()
