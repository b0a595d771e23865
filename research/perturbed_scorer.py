"""Perturbed-start scores learned: issue 46's "the scorer learns from it; check whether this raises
the measured success of the chosen plans", with the simulated perturbed-start counts as labels.

    python -m research.perturbed_scorer label [--seeds 40-45] [--per-assembly 120] [--work DIR]
    python -m research.perturbed_scorer evaluate [--work DIR] [--jsonl FILE] [--choice] [ASSEMBLY ...]

**label**: for every family of ``rap.geometry.families`` and seed of ``--seeds`` (none of them an
evaluated assembly's), the generated assembly with the default options, if its AND/OR graph has
at most ``PERTURBED_MAX_OPERATIONS`` operations; up to ``--per-assembly`` of its operations that
are not free (drawn with a seeded generator), each labelled with its perturbed-start successes
(``rap.execution.perturbed``, 100 trials, the shipped cell's errors, on 2 worker processes) and
described by its twelve descriptors (``rap.model.data.descriptors``) and the shipped scorer's
expected exact-start score. One JSON file of rows per assembly under ``--work`` (default
``/tmp/perturbed_scorer``), so a rerun resumes.

**evaluate**: LightGBM trees (the shipped scorer's settings, ``research.descriptor_scorer``) on
those 13 features, the cross-entropy on the perturbed success rates, fitted on every labelled
row; their accuracy by 5-fold cross-validation grouped by assembly against the exact-start
expected score as the predictor. Then per evaluated assembly (``benchmarks/best_sequence.py``'s
twelve by default): the optimal DP over the learned perturbed scores (free operations 1), and
that plan re-measured by 2,000 rollouts on the best-of-all table's re-measurement seed, beside
the default's plan and the best of all sequences (``research/best_sequence.jsonl``), and the
plan of the simulated perturbed scores (``research/perturbed_candidate.jsonl``). ``--choice``:
also whether the choice (``rap.plan.execution.choose`` on the problem's root seed, as ``plan``
runs it) would take the learned plan over the default's.

Cost: labels about 0.15 s of a core an operation (some 8,000: 10-15 minutes on 2 cores), the
trees seconds, the re-measurements about a minute an assembly.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REMEASURE_SEED = 3_000_017  # benchmarks/best_sequence.py's: the rows compare
FEATURES = "descriptors + expected exact-start score"


def _problem_of(asm, cell):
    from rap.commands._rollouts import cell_errors, mm_per_unit
    from rap.plan.problem import PlanningProblem
    from rap.seeds import DEFAULT_ROOT_SEED
    from rap.sim.params import SimParams

    return (PlanningProblem(asm, SimParams(), DEFAULT_ROOT_SEED), cell_errors(cell),
            mm_per_unit(cell, asm))


def features(problem, ops, model) -> np.ndarray:
    """float64 [N, 13]: the twelve descriptors and the shipped scorer's expected score."""
    from rap.model.data.descriptors import DescriptorContext, descriptors_for

    desc = descriptors_for(DescriptorContext(problem.assembly), ops).astype(float)
    return np.column_stack([desc, np.asarray(model.expected_score(problem, ops), dtype=float)])


def _non_free(problem, graph) -> list:
    seen = {}
    for ops in graph.values():
        for op in ops:
            if not problem.is_free(op):
                seen.setdefault(problem.key(op), op)
    return list(seen.values())


def label_command(seeds: list[int], per_assembly: int, work: Path) -> None:
    from rap.geometry.families import ALL_FAMILIES, generate
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan.execution import PERTURBED_MAX_OPERATIONS
    from rap.plan.graph import TooLarge, reachable
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell

    work.mkdir(parents=True, exist_ok=True)
    cell = Cell()
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    sim = LocalSimulator(processes=2)
    try:
        for family in ALL_FAMILIES:
            for seed in seeds:
                out = work / f"{family}-s{seed}.json"
                if out.exists():
                    continue
                t0 = time.perf_counter()
                asm = generate(family, seed)
                problem, errors, mm = _problem_of(asm, cell)
                try:
                    graph = reachable(problem, PERTURBED_MAX_OPERATIONS)
                except TooLarge:
                    out.write_text(json.dumps({"assembly": asm.name, "rows": [],
                                               "skipped": "too large"}))
                    continue
                ops = _non_free(problem, graph)
                rng = np.random.default_rng([seed, len(family)])
                if len(ops) > per_assembly:
                    ops = [ops[i] for i in sorted(rng.choice(len(ops), per_assembly,
                                                             replace=False))]
                x = features(problem, ops, model) if ops else np.zeros((0, 13))
                wins = sim.run_perturbed([(asm, op, problem.params, errors, mm, problem.seed(op))
                                          for op in ops])
                rows = [{"x": [float(v) for v in xi], "successes": int(w),
                         "trials": problem.params.trials} for xi, w in zip(x, wins)]
                out.write_text(json.dumps({"assembly": asm.name, "family": family,
                                           "parts": len(asm.parts), "rows": rows}))
                print(f"{asm.name}: {len(rows)} operations, {time.perf_counter() - t0:.0f} s",
                      flush=True)
    finally:
        sim.close()


def _rows(work: Path):
    x, s, t, group = [], [], [], []
    for k, path in enumerate(sorted(work.glob("*.json"))):
        for row in json.loads(path.read_text())["rows"]:
            x.append(row["x"])
            s.append(row["successes"])
            t.append(row["trials"])
            group.append(k)
    return np.array(x), np.array(s, float), np.array(t, float), np.array(group)


def fit(x: np.ndarray, successes: np.ndarray, trials: np.ndarray, seed: int = 0):
    """LightGBM trees on the rows (the shipped scorer's settings), a booster."""
    import lightgbm

    from research.descriptor_scorer import GBT_PARAMS, GBT_ROUNDS

    data = lightgbm.Dataset(x, label=successes / trials, weight=trials / 100.0)
    return lightgbm.train({**GBT_PARAMS, "seed": seed}, data, GBT_ROUNDS)


def cross_validate(x, successes, trials, group, folds: int = 5) -> dict:
    """Mean absolute error of the trees (5 folds by assembly) and of the expected exact-start
    score, against the perturbed success rate; how often each is off by more than 0.2."""
    rate = successes / trials
    pred = np.zeros(len(rate))
    ids = np.unique(group)
    fold_of = {g: i % folds for i, g in enumerate(np.random.default_rng(0).permutation(ids))}
    fold = np.array([fold_of[g] for g in group])
    for f in range(folds):
        test = fold == f
        pred[test] = fit(x[~test], successes[~test], trials[~test]).predict(x[test])
    exact = x[:, -1]
    return {"rows": int(len(rate)), "assemblies": int(len(ids)),
            "mae_trees": float(np.mean(np.abs(pred - rate))),
            "mae_exact_score": float(np.mean(np.abs(exact - rate))),
            "off_0.2_trees": float(np.mean(np.abs(pred - rate) > 0.2)),
            "off_0.2_exact_score": float(np.mean(np.abs(exact - rate) > 0.2))}


def _chosen(problem, opts, sim, model, learned_plan) -> bool:
    """Whether the choice (``rap.plan.execution.choose`` on the problem's root seed) takes
    ``learned_plan`` over the default's plan (``rap.plan.plan`` with its rollouts)."""
    from rap.plan import plan
    from rap.plan.execution import choose
    from rap.plan.scoring.cache import ScoreCache

    default = plan(problem, simulator=sim, cache=ScoreCache(), model=model, execution=opts,
                   alternatives=3)
    chosen, _ = choose(problem, [default, learned_plan], sim, opts, int(problem.root_seed))
    return chosen == 1


def evaluate_command(names: list[str], work: Path, jsonl: Path | None, remeasure: int,
                     choice: bool = False) -> None:
    from benchmarks.best_sequence import DEFAULT, small_case
    from rap.execution.sequence import measure
    from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
    from rap.plan.graph import reachable
    from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
    from rap.plan.execution import rollout_plan
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.robot.cell import Cell
    from rap.stats import rate
    from research.perturbed_starts import best_sequence

    x, s, t, group = _rows(work)
    cv = cross_validate(x, s, t, group)
    print(f"trees on {FEATURES}: {cv}", flush=True)
    booster = fit(x, s, t)
    best_rows = {json.loads(line)["assembly"]: json.loads(line)
                 for line in (ROOT / "research" / "best_sequence.jsonl").read_text().splitlines()}
    pert_rows = {json.loads(line)["assembly"]: json.loads(line) for line in
                 (ROOT / "research" / "perturbed_candidate.jsonl").read_text().splitlines()}
    cell = Cell()
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    sim = LocalSimulator(processes=2)
    print("| assembly | operations | learned-perturbed plan, re-measured | default | simulated-"
          "perturbed candidate (with) | best of all | learned / default |"
          + (" the choice |" if choice else ""))
    print("|---|---:|---|---|---|---|---:|" + ("---|" if choice else ""))
    try:
        for name in names or DEFAULT:
            asm, problem, opts = small_case(name, cell)
            graph = reachable(problem)
            ops = _non_free(problem, graph)
            learned = dict(zip((problem.key(op) for op in ops),
                               booster.predict(features(problem, ops, model)) if ops else []))
            score = {problem.key(op): learned.get(problem.key(op), 1.0)
                     for c in graph.values() for op in c}
            _, seq = best_sequence(problem, graph, score)
            plan = PlanResult(PlanStatus.FOUND, "search", asm.name,
                              steps=tuple(PlanStep.of(op, "sim") for op in seq))
            got = measure(asm, rollout_plan(problem, plan, opts), sim, REMEASURE_SEED,
                          rollouts=remeasure).success
            b = best_rows.get(asm.name, {})
            default = rate(b["default"]["successes"], b["default"]["trials"]) if b else None
            best = rate(b["best"]["successes"], b["best"]["trials"]) if b else None
            w = pert_rows.get(asm.name, {}).get("with")
            with_ = rate(w["successes"], w["trials"]) if w else None
            row = {"assembly": asm.name, "operations": len(ops), "learned": got.to_dict(),
                   "steps": [sorted(op.moving) for op in seq], "cv": cv}
            if choice:
                row["chosen"] = _chosen(problem, opts, sim, model, plan)
            ratio = f"{got.value / default.value:.2f}" if default and default.value else "-"
            print(f"| {asm.name} | {len(ops)} | {got.text()} | "
                  f"{default.text() if default else '-'} | {with_.text() if with_ else '-'} | "
                  f"{best.text() if best else '-'} | {ratio} |"
                  + (f" {'chosen' if row['chosen'] else 'not chosen'} |" if choice else ""),
                  flush=True)
            if jsonl:
                with jsonl.open("a") as fh:
                    fh.write(json.dumps(row) + "\n")
    finally:
        sim.close()


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    lab = sub.add_parser("label")
    lab.add_argument("--seeds", default="40-45")
    lab.add_argument("--per-assembly", type=int, default=120)
    lab.add_argument("--work", type=Path, default=Path("/tmp/perturbed_scorer"))
    ev = sub.add_parser("evaluate")
    ev.add_argument("assemblies", nargs="*")
    ev.add_argument("--work", type=Path, default=Path("/tmp/perturbed_scorer"))
    ev.add_argument("--jsonl", type=Path)
    ev.add_argument("--remeasure", type=int, default=2000)
    ev.add_argument("--choice", action="store_true")
    args = ap.parse_args()
    if args.command == "label":
        label_command(_seeds(args.seeds), args.per_assembly, args.work)
    else:
        evaluate_command(args.assemblies, args.work, args.jsonl, args.remeasure, args.choice)


if __name__ == "__main__":
    main()
