"""Choose search's ``--trust`` on held-out assemblies without timing anything.

For each (assembly, hold-out model) pair: every operation of the assembly's AND/OR graph gets the
model's expected score and the simulator's score (the corpus's label where the corpus has that
operation, else a fresh simulation with the same seed: the same number). ``SearchPlanner`` then
plans against these tables (a stand-in simulator that looks scores up), for each trust value, and
the plan's robustness is compared with the optimum's (the DP over the simulator's scores).

    python scripts/search_validation.py --set validation [--trust 0.93,0.95,0.96,0.97,0.98]
    python scripts/search_validation.py --set test --trust none --optimism 0,0.2,0.4,1
    python scripts/search_validation.py --set unseen --model OTHER.pt --trust none --optimism 0,0.1

``validation``: 3 seeds of each of the 9 generated families that have a leave-one-family-out model,
none of them an experiment (test) assembly; ``test``: the 14 assemblies of `rap-farm experiment`
in docs/RESULTS.md; ``fresh``: one fresh seed of each of the ten families (``fresh_assemblies``),
a validation set for the shipped model; ``unseen``: the 12 assemblies of `scripts/make_unseen.py` with an optimum in
docs/RESULTS.md (fan-s100 has 11,253 operations), with the shipped model (labels from
datasets/unseen). The tables are cached in ``--cache`` (default reports/search-validation/);
building them simulates a few thousand operations (about 15 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import math
import pickle
import statistics
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SEED = 20190527  # the corpus's root seed (datasets/corpus/_rapfarm.json)
TEST = ["grid", "hexagon", "mixed-square", "pentagons", "rectilinear", "c-shapes-s20",
        "convex-s26", "fan-s12", "funnels-s2", "hub-s32", "knobs-s27", "packing-s25", "pegs-s5",
        "polyomino-s33"]
VALIDATION = ["c-shapes-s10", "c-shapes-s17", "c-shapes-s19", "convex-s11", "convex-s14",
              "convex-s20", "fan-s1", "fan-s10", "fan-s18", "funnels-s10", "funnels-s11",
              "funnels-s12", "hub-s0", "hub-s12", "hub-s2", "knobs-s10", "knobs-s16", "knobs-s17",
              "packing-s11", "packing-s12", "packing-s19", "pegs-s1", "pegs-s15", "pegs-s22",
              "polyomino-s11", "polyomino-s14", "polyomino-s26"]
FRESH_FROM, FRESH_PARTS, FRESH_OPERATIONS = 200, (7, 10), 2000  # the fresh set (fresh_assemblies)
UNSEEN = ["basketweave", "c-shapes-s100", "convex-s102", "funnels-s103", "hub-s101", "knobs-s101",
          "packing-s100", "pegs-s103", "pentomino-6x10", "polyomino-s100", "tangram", "wall-s101"]


def fresh_assemblies() -> dict:
    """The ``fresh`` set: per generated family the first seed from 200 on (the corpus holds 0-35,
    the unseen set 100-103) whose assembly has 7 to 10 parts and at most 2,000 operations in its
    AND/OR graph; a validation set for the shipped
    model, disjoint from the unseen test set. Written to ``reports/fresh-assemblies/``."""
    import json

    from rap.assembly import assembly_to_json
    from rap.geometry.families import FAMILIES, generate

    out = ROOT / "reports" / "fresh-assemblies"
    out.mkdir(parents=True, exist_ok=True)
    from rap.plan.problem import PlanningProblem
    from rap.plan.graph import TooLarge, reachable
    from rap.sim.params import SimParams

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
    if name in UNSEEN or (ROOT / "reports" / "fresh-assemblies" / f"{name}.json").exists():
        return ROOT / "rap" / "data" / "default_model.pt"
    family = name.rsplit("-s", 1)[0] if "-s" in name and name[-1].isdigit() else None
    stem = f"holdout-family-{family}" if family else f"holdout-{name}"
    return ROOT / "reports" / "holdout-models" / f"{stem}.pt"


def assembly_path(name: str) -> Path:
    if name in UNSEEN:
        return ROOT / "assemblies" / "unseen" / f"{name}.json"
    fresh = ROOT / "reports" / "fresh-assemblies" / f"{name}.json"
    if fresh.exists():
        return fresh
    p = ROOT / "assemblies" / f"{name}.json"
    return p if p.exists() else ROOT / "datasets" / "corpus" / "_assemblies" / f"{name}.json"


def problem_of(name: str):
    from rap.io import load_assembly
    from rap.plan.problem import PlanningProblem
    from rap.sim.params import SimParams

    return PlanningProblem(load_assembly(assembly_path(name)), SimParams(), SEED)


def predictions(name: str, mirror: bool = False, model: Path | None = None,
                what: str = "expected_score") -> dict:
    """key -> the hold-out model's (or ``model``'s) expected score (``what="prob_high"``: its
    P(high), what RAP acts on), for every operation of the graph."""
    from rap.model.inference import PredictorCnn
    from rap.plan.graph import reachable

    problem = problem_of(name)
    ops = [op for c in reachable(problem).values() for op in c]
    cnn = PredictorCnn.load(model or model_of(name), engine="auto", mirror=mirror)
    return dict(zip([problem.key(op) for op in ops],
                    map(float, getattr(cnn, what)(problem, ops))))


def tables(name: str, dataset) -> dict:
    """{"pred": key -> expected score, "truth": key -> simulated score} for every operation."""
    import pyarrow.dataset as ds

    from rap.plan.local_simulator import LocalSimulator
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


class _LookupSim:
    def __init__(self, truth):
        self.truth = truth

    def simulate_many(self, problem, ops):
        from rap.plan.cache import CachedScore

        return [CachedScore(self.truth[problem.key(op)], round(self.truth[problem.key(op)] * 100),
                            100) for op in ops]


class _LookupCnn:
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

    def prob_high_and_expected(self, problem, ops):  # one CNN call, as PredictorCnn's
        return self.prob_high(problem, ops), self.expected_score(problem, ops)


def evaluate(name: str, tab: dict, trust: float | None, simulations: int,
             optimism: float = 0.0) -> tuple[float, int]:
    """(R / R optimal, simulations while planning) of search on the lookup tables."""
    from rap.plan.cache import ScoreCache
    from rap.plan.graph import dp_choice, reachable
    from rap.plan.scorers import Scorer
    from rap.plan.search import SearchPlanner

    problem = problem_of(name)
    graph = reachable(problem)
    best, _ = dp_choice(graph, {s: [tab["truth"][problem.key(op)] for op in c]
                                for s, c in graph.items()})
    result = SearchPlanner(simulations=simulations, trust=trust, optimism=optimism).solve(
        problem, Scorer(_LookupSim(tab["truth"]), _LookupCnn(tab["pred"]), ScoreCache()))
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("validation", "test", "unseen", "fresh"), default="validation")
    ap.add_argument("--trust", default="0.93,0.95,0.96,0.97,0.98,none")
    ap.add_argument("--simulations", type=int, default=1000, help="budget per plan")
    ap.add_argument("--optimism", default="0", help="comma-separated optimism values to try")
    ap.add_argument("--mirror", action="store_true",
                    help="predictions averaged over each pair and its mirror image")
    ap.add_argument("--model", type=Path,
                    help="predictions of this checkpoint instead (--set unseen: one no model "
                         "here was trained on); the same simulator scores")
    ap.add_argument("--metrics", action="store_true",
                    help="also the predictions' agreement with the simulator on the whole graphs")
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    a = ap.parse_args()
    if a.model is not None and a.set not in ("unseen", "fresh"):
        ap.error("--model needs --set unseen or fresh (the other sets' models are hold-out models)")
    if a.model is not None and a.mirror:
        ap.error("--model and --mirror: one at a time")
    names = (list(fresh_assemblies()) if a.set == "fresh"
             else {"validation": VALIDATION, "test": TEST, "unseen": UNSEEN}[a.set])
    a.cache.mkdir(parents=True, exist_ok=True)
    path = a.cache / f"{a.set}.pkl"
    tabs = pickle.loads(path.read_bytes()) if path.exists() else {}
    missing = [n for n in names if n not in tabs]
    if missing:
        import pyarrow.dataset as ds

        labels = ROOT / "datasets" / {"unseen": "unseen", "fresh": "fresh"}.get(a.set, "corpus")
        dataset = (ds.dataset(str(labels), format="parquet", exclude_invalid_files=True)
                   if labels.is_dir() else None)  # None: every operation simulated here
        print(f"building score tables for {len(missing)} assemblies ...", flush=True)
        for n in missing:
            tabs[n] = tables(n, dataset)
            path.write_bytes(pickle.dumps(tabs))  # resumable: one assembly at a time
    if a.mirror:  # the same simulator scores, mirror-averaged predictions
        mpath = a.cache / f"{a.set}-mirror.pkl"
        mirror = pickle.loads(mpath.read_bytes()) if mpath.exists() else {}
        for n in names:
            if n not in mirror:
                mirror[n] = predictions(n, mirror=True)
                mpath.write_bytes(pickle.dumps(mirror))
        tabs = {n: {"pred": mirror[n], "truth": tabs[n]["truth"]} for n in names}
    if a.model is not None:  # the same simulator scores, another checkpoint's predictions
        import hashlib

        digest = hashlib.sha256(a.model.read_bytes()).hexdigest()[:12]
        ppath = a.cache / f"{a.set}-model-{digest}.pkl"
        other = pickle.loads(ppath.read_bytes()) if ppath.exists() else {}
        for n in names:
            if n not in other:
                other[n] = predictions(n, model=a.model)
                ppath.write_bytes(pickle.dumps(other))
        tabs = {n: {"pred": other[n], "truth": tabs[n]["truth"]} for n in names}
    print(f"{a.set}: {len(names)} assemblies, search with up to {a.simulations} simulations"
          + (", mirror-averaged predictions" if a.mirror else "")
          + (f", predictions of {a.model}" if a.model else ""))
    if a.metrics:
        ms = [prediction_metrics(n, tabs[n]) for n in names]
        print("predictions on the whole graphs (mean over assemblies): "
              + ", ".join(f"{k} {statistics.mean(m[k] for m in ms):.3f}" for k in ms[0]))
    print(f"{'trust':>6} {'optimism':>8} {'R/R opt':>8} {'worst':>6} {'sims':>6}")
    for t in a.trust.split(","):
        trust = None if t == "none" else float(t)
        for u in a.optimism.split(","):
            res = [evaluate(n, tabs[n], trust, a.simulations, float(u)) for n in names]
            ratios = [r for r, _ in res]
            print(f"{t:>6} {u:>8} {statistics.mean(ratios):8.3f} {min(ratios):6.3f} "
                  f"{statistics.mean(s for _, s in res):6.1f}", flush=True)


if __name__ == "__main__":
    main()
