"""Score tables of held-out assemblies: every operation's prediction beside its simulated score.

The library behind ``research/search_validation.py`` (which builds and caches the tables and
chooses search's ``--trust`` and optimism), ``research/rap_validation.py`` (RAP's decision rule)
and ``research/planning_bounds.py`` (what a perfect scorer would still cost). Planners are replayed
on a table through the real ``Scorer`` with look-up backends (``LookupSimulator``, ``LookupCnn``),
so no simulation and no network runs while they plan.

The assembly sets are data: ``datasets/splits.json`` (``test``, ``validation``, ``unseen`` and the
rule of ``fresh``), read by ``load_splits`` and named by ``assemblies_of``.

* ``tables(name, dataset)``: ``{"pred", "phigh", "truth"}``: per operation key of the assembly's
  AND/OR graph, the model's expected score and P(high) and the simulator's score (the dataset's
  label where it has one, else a fresh simulation with the same seed: the same number). Cost:
  one CNN pass over the graph and the simulations missing from the dataset.
* ``evaluate(name, tab, trust, simulations, optimism)``: search on the table against the optimum.
* ``prediction_metrics(name, tab)``: how the predictions match the simulator on the whole graph.

Run from the repository root (paths are relative to it): ``python -m research.search_validation``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["ROOT", "SEED", "SPLITS", "load_splits", "assemblies_of", "TEST", "VALIDATION",
           "UNSEEN", "fresh_assemblies", "model_of", "assembly_path", "problem_of", "predictions",
           "tables", "LookupSimulator", "LookupCnn", "evaluate", "prediction_metrics"]

ROOT = Path(__file__).resolve().parents[1]
SEED = 20190527  # the corpus's root seed (datasets/corpus/_rapfarm.json)
SPLITS = ROOT / "datasets" / "splits.json"


def load_splits(path: Path = SPLITS) -> dict:
    """The assembly splits (``datasets/splits.json``)."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


_SPLITS = load_splits()
TEST: list[str] = _SPLITS["test"]["assemblies"]
VALIDATION: list[str] = _SPLITS["validation"]["assemblies"]
UNSEEN: list[str] = _SPLITS["unseen"]["assemblies"]
FRESH_FROM: int = _SPLITS["fresh"]["from_seed"]
FRESH_PARTS: tuple[int, int] = tuple(_SPLITS["fresh"]["parts"])
FRESH_OPERATIONS: int = _SPLITS["fresh"]["max_operations"]


def assemblies_of(split: str) -> list[str]:
    """The assembly names of a split: ``test``, ``validation``, ``unseen`` or ``fresh`` (found,
    and written, by ``fresh_assemblies``)."""
    if split == "fresh":
        return list(fresh_assemblies())
    return {"validation": VALIDATION, "test": TEST, "unseen": UNSEEN}[split]


def fresh_assemblies() -> dict:
    """The ``fresh`` set (``datasets/splits.json``): per generated family the first seed from
    ``FRESH_FROM`` (200) on (the corpus holds 0-35, the unseen set 100-103) whose assembly has
    ``FRESH_PARTS`` (7 to 10) parts and at most ``FRESH_OPERATIONS`` (2,000) operations in its
    AND/OR graph; a validation set for the shipped model, disjoint from the unseen test set.
    Written to ``reports/fresh-assemblies/``: name -> path."""
    from rap.assembly import assembly_to_json
    from rap.geometry.families import FAMILIES, generate
    from rap.plan.graph import TooLarge, reachable
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    out = ROOT / "reports" / "fresh-assemblies"
    out.mkdir(parents=True, exist_ok=True)

    def small(a) -> bool:  # at most FRESH_OPERATIONS operations: tables in minutes
        try:
            reachable(PlanningProblem(a, SimParams(), SEED), FRESH_OPERATIONS)
        except TooLarge:
            return False
        return True

    found = {}
    for family in FAMILIES:
        seed = FRESH_FROM
        while not (FRESH_PARTS[0] <= len(a := generate(family, seed)) <= FRESH_PARTS[1]
                   and small(a)):
            seed += 1
        path = out / f"{a.name}.json"
        if not path.exists():
            path.write_text(json.dumps(assembly_to_json(a), separators=(",", ":")) + "\n")
        found[a.name] = path
    return found


def model_of(name: str) -> Path:
    """The checkpoint whose predictions an assembly's tables hold: the shipped model for the
    unseen and fresh sets, else the hold-out model that has not seen it (or its family)."""
    if name in UNSEEN or (ROOT / "reports" / "fresh-assemblies" / f"{name}.json").exists():
        return ROOT / "rap" / "data" / "default_model.pt"
    family = name.rsplit("-s", 1)[0] if "-s" in name and name[-1].isdigit() else None
    stem = f"holdout-family-{family}" if family else f"holdout-{name}"
    return ROOT / "reports" / "holdout-models" / f"{stem}.pt"


def assembly_path(name: str) -> Path:
    """The assembly file of ``name``: assemblies/unseen/, reports/fresh-assemblies/, assemblies/ or
    datasets/corpus/_assemblies/."""
    if name in UNSEEN:
        return ROOT / "assemblies" / "unseen" / f"{name}.json"
    fresh = ROOT / "reports" / "fresh-assemblies" / f"{name}.json"
    if fresh.exists():
        return fresh
    p = ROOT / "assemblies" / f"{name}.json"
    return p if p.exists() else ROOT / "datasets" / "corpus" / "_assemblies" / f"{name}.json"


def problem_of(name: str):
    """The planning problem of ``name`` at the simulator's defaults and the corpus's root seed."""
    from rap.io import load_assembly
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    return PlanningProblem(load_assembly(assembly_path(name)), SimParams(), SEED)


def predictions(name: str, mirror: bool = False, model: Path | None = None,
                what: str = "expected_score") -> dict:
    """key -> the hold-out model's (or ``model``'s) expected score (``what="prob_high"``: its
    P(high), what RAP acts on), for every operation of the graph."""
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.graph import reachable

    problem = problem_of(name)
    ops = [op for c in reachable(problem).values() for op in c]
    cnn = OperationPredictor.load(model or model_of(name), engine="cnn", mirror=mirror)
    return dict(zip([problem.key(op) for op in ops],
                    map(float, getattr(cnn, what)(problem, ops))))


def saved_tables(cache: Path, split: str, names: list[str]) -> dict:
    """The score tables of ``names`` cached by ``research.search_validation --set split`` in
    ``cache`` (name -> table); exits with one line naming the command when some are missing."""
    import pickle
    import sys

    path = Path(cache) / f"{split}.pkl"
    tabs = pickle.loads(path.read_bytes()) if path.exists() else {}
    missing = [n for n in names if n not in tabs]
    if missing:
        sys.exit(f"{path}: no tables for {', '.join(missing)}; run python -m "
                 f"research.search_validation --set {split} --trust none first")
    return tabs


def tables(name: str, dataset) -> dict:
    """{"pred": key -> expected score, "truth": key -> simulated score} for every operation."""
    import pyarrow.dataset as ds

    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.graph import reachable

    problem = problem_of(name)
    ops = [op for c in reachable(problem).values() for op in c]
    keys = [problem.key(op) for op in ops]
    truth = {}
    if dataset is not None:  # labels already simulated with the same seeds: the same numbers
        t = dataset.to_table(columns=["key", "score"], filter=ds.field("assembly") == name)
        truth = {k: v for k, v in zip(t["key"].to_pylist(), t["score"].to_pylist())}
    todo = [op for op, k in zip(ops, keys) if k not in truth]
    sim = LocalSimulator(processes=2, min_batch=1)
    try:
        for op, r in zip(todo, sim.simulate_many(problem, todo)):
            truth[problem.key(op)] = r.score
    finally:
        sim.close()
    print(f"  {name}: {len(ops)} operations, {len(todo)} simulated", flush=True)
    return {"pred": predictions(name), "phigh": predictions(name, what="prob_high"),
            "truth": {k: truth[k] for k in keys}}


class LookupSimulator:
    """A simulator backend that looks the scores up in a table (key -> simulated score), as 100
    trials."""

    def __init__(self, truth):
        self.truth = truth

    def simulate_many(self, problem, ops):
        from rap.plan.scoring.cache import CachedScore

        return [CachedScore(self.truth[problem.key(op)], round(self.truth[problem.key(op)] * 100),
                            100) for op in ops]


class LookupCnn:
    """The model's numbers from the tables: expected scores, and P(high) when given (else the
    expected score stands in for it)."""

    meta: dict = {}

    def __init__(self, pred, phigh=None):
        self.pred = pred
        self.phigh = pred if phigh is None else phigh

    def expected_score(self, problem, ops):
        return np.array([self.pred[problem.key(op)] for op in ops])

    def prob_high(self, problem, ops):
        return np.array([self.phigh[problem.key(op)] for op in ops])

    def prob_high_and_expected(self, problem, ops):  # one CNN call, as OperationPredictor's
        return self.prob_high(problem, ops), self.expected_score(problem, ops)


def evaluate(name: str, tab: dict, trust: float | None, simulations: int,
             optimism: float = 0.0) -> tuple[float, int]:
    """(R / R optimal, simulations while planning) of search on the lookup tables."""
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.dp import dp_choice
    from rap.plan.graph import reachable
    from rap.plan.scoring.scorer import Scorer
    from rap.plan.search.planner import SearchPlanner

    problem = problem_of(name)
    graph = reachable(problem)
    best, _ = dp_choice(graph, {s: [tab["truth"][problem.key(op)] for op in c]
                                for s, c in graph.items()})
    result = SearchPlanner(simulations=simulations, trust=trust, optimism=optimism, upper=0.0).solve(
        problem, Scorer(LookupSimulator(tab["truth"]), LookupCnn(tab["pred"]), ScoreCache(), free_by_geometry=False))
    r = math.prod(tab["truth"][problem.key(s.operation)] for s in result.steps)
    return r / best[problem.whole], int(result.stats["search_simulations"])


def prediction_metrics(name: str, tab: dict) -> dict:
    """How the predictions match the simulator on the whole graph: accuracy of the class at 0.95,
    mean absolute error, mean |log p - log s| (scores floored at 0.01: the DP multiplies), and
    the fraction of candidate pairs of one subassembly, whose simulated scores differ by at least
    0.05, that the predictions order the same way (what the DP's choices rest on)."""
    from rap.plan.graph import reachable

    problem = problem_of(name)
    pred, truth = tab["pred"], tab["truth"]
    p = np.array([pred[k] for k in truth])
    t = np.array(list(truth.values()))
    good = pairs = 0
    for cands in reachable(problem).values():
        ks = [problem.key(op) for op in cands]
        for i, a in enumerate(ks):
            for b in ks[i + 1:]:
                if abs(truth[a] - truth[b]) >= 0.05:
                    pairs += 1
                    good += (pred[a] - pred[b]) * (truth[a] - truth[b]) > 0
    return {"accuracy": float(((p >= 0.95) == (t >= 0.95)).mean()),
            "mae": float(np.abs(p - t).mean()),
            "log_error": float(np.abs(np.log(np.maximum(p, 0.01))
                                      - np.log(np.maximum(t, 0.01))).mean()),
            "pair_order": good / pairs if pairs else float("nan")}
