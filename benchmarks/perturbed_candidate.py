"""The default plan with and without ``--perturbed-candidate``, both re-measured, against the best
of all sequences (issue 46's choice; docs/ROBOT.md, "The best of all sequences").

    python benchmarks/perturbed_candidate.py --best ROWS.jsonl [--jsonl FILE] [ASSEMBLY.json ...]

Per assembly (the default problem, root seed ``DEFAULT_ROOT_SEED``, the shipped cell's errors
carried, tolerances off): ``rap.plan.plan`` with rollouts and 3 candidates, then the same with
``ExecutionOptions(perturbed=True)`` (the best plan on perturbed-start scores offered to the
choice too, ``rap.plan.execution.perturbed_candidate``), each on a fresh score cache; both
re-measured by 2,000 rollouts on ``benchmarks/best_sequence.py``'s re-measurement seed, so that
they compare with its best of all sequences (``--best``: its JSON lines). Prints a Markdown row
per assembly: the plan chosen with the option (its R; ``perturbed`` when the perturbed candidate
was chosen), without it, the best of all, and the option's time over the default's.

Cost: the perturbed scores (one simulation of every operation that is not free: 0.15 s a core
each) and the two plans' rollouts; a few minutes for the eleven of the table on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.best_sequence import DEFAULT, REMEASURE_SEED, small_case  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--best", type=Path, help="benchmarks/best_sequence.py's JSON lines")
    ap.add_argument("--jsonl", type=Path, help="append one JSON line per assembly")
    ap.add_argument("--remeasure", type=int, default=2000)
    args = ap.parse_args()
    from dataclasses import replace

    from rap.execution.sequence import measure
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan import plan
    from rap.plan.execution import rollout_plan
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell

    best = {}
    if args.best:
        for line in args.best.read_text().splitlines():
            row = json.loads(line)
            best[row["assembly"]] = row["best"]
    cell = Cell()
    sim = LocalSimulator(processes=2)
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    print("| assembly | operations | with the perturbed candidate (R) | default (R) | "
          "best of all | with - best | time: with / default |")
    print("|---|---:|---|---|---|---:|---:|")
    try:
        for name in args.assemblies or DEFAULT:
            asm, problem, opts = small_case(name, cell)
            t0 = time.perf_counter()
            default = plan(problem, simulator=sim, cache=ScoreCache(), model=model,
                           execution=opts, alternatives=3)
            t1 = time.perf_counter()
            with_it = plan(problem, simulator=sim, cache=ScoreCache(), model=model,
                           execution=replace(opts, perturbed=True), alternatives=3)
            t2 = time.perf_counter()
            rates = [measure(asm, rollout_plan(problem, p, opts), sim, REMEASURE_SEED,
                             rollouts=args.remeasure).success for p in (with_it, default)]
            picked = next(c for c in with_it.sequence.candidates if c["chosen"])
            b = best.get(asm.name)
            row = {"assembly": asm.name, "parts": len(asm.parts),
                   "perturbed_simulated": with_it.stats.get("perturbed_simulated"),
                   "chose_perturbed": bool(picked.get("perturbed_starts")),
                   "with": rates[0].to_dict(), "default": rates[1].to_dict(),
                   "best_of_all": b, "seconds": [round(t2 - t1, 2), round(t1 - t0, 2)]}
            print(f"| {asm.name} | {row['perturbed_simulated']} | {rates[0].text()} "
                  f"({with_it.robustness:.3f}{', perturbed' if row['chose_perturbed'] else ''}) | "
                  f"{rates[1].text()} ({default.robustness:.3f}) | "
                  f"{'-' if b is None else format(b['rate'], '.3f')} | "
                  f"{'-' if b is None else format(rates[0].value - b['rate'], '+.3f')} | "
                  f"{(t2 - t1) / (t1 - t0):.2f} |", flush=True)
            if args.jsonl:
                with args.jsonl.open("a") as f:
                    f.write(json.dumps(row) + "\n")
    finally:
        sim.close()


if __name__ == "__main__":
    main()
