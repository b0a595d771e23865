"""Where search's planning time goes, and whether bigger CNN batches would pay.

Part 1 (``--profile``, default on): plans each assembly with ``search-s200-o10`` (the shipped
model, two forked simulation workers, a cold score cache) with timers around the renderer, the
CNN's forward passes, the simulator and candidate enumeration; prints seconds per phase.

Part 2: the CNN's cost per operation by batch size (``TorchPredictor`` on this machine, measured here)
and the renderer's per operation; then, with every operation's prediction computed once, the
branch and bound of ``rap.plan.dp`` replayed under three scoring orders, reporting the
operations scored, the batches and the model time they would cost under the measured table:

- ``lazy``: one batch per subassembly visited (what ``SearchPlanner`` does);
- ``kids``: a subassembly's candidates with those of its candidates' children (bigger batches,
  more operations);
- ``eager``: the whole graph in one batch (``research.variants.eager.EagerSearchPlanner``).

    python -m research.benchmarks.search_costs [--no-profile] [NAME ...]   # default: assemblies/unseen

The replay's plans must equal ``lazy``'s (checked). One run, so machine noise hits all alike.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

BATCHES = (1, 2, 4, 8, 16, 32, 64)


def _timed(obj, attr: str, totals: dict, label: str) -> None:
    f = getattr(obj, attr)

    def g(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            totals[label] = totals.get(label, 0.0) + time.perf_counter() - t

    setattr(obj, attr, g)


def profile(names, assemblies, params, seed, model) -> None:
    from rap.plan.scoring.cache import ScoreCache
    from rap.experiment.run import method_planner
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.scoring.scorer import Scorer

    cnn = OperationPredictor.load(model)
    sim = LocalSimulator(processes=2, prestart=True)
    totals: dict = {}
    _timed(sim, "simulate_many", totals, "simulate")
    _timed(cnn, "images", totals, "render")
    _timed(cnn, "_forward", totals, "forward")
    time.sleep(3)  # the workers load the simulator
    print("search-s200-o10: seconds per phase")
    print(f"{'assembly':16s} {'plan':>6s} {'render':>7s} {'forward':>8s} {'simulate':>9s} "
          f"{'candidates':>10s}")
    sums: dict = {}
    try:
        for name in names:
            problem = PlanningProblem(assemblies[name], params, seed, "online")
            _timed(problem, "candidates", totals, "candidates")
            scorer = Scorer(sim, cnn, ScoreCache())
            scorer.cnn.prob_high(problem, list(problem.candidates(problem.whole))[:1])  # warm
            totals.clear()
            res = method_planner("search-s200-o10").solve(problem, scorer)
            row = {"plan": res.seconds, **totals}
            row["simulate"] = row.get("simulate", 0.0) - res.eval_seconds  # planning's only
            for k, v in row.items():
                sums[k] = sums.get(k, 0.0) + v
            print(f"{name:16s} {row['plan']:6.2f} {row.get('render', 0):7.2f} "
                  f"{row.get('forward', 0):8.2f} {row['simulate']:9.2f} "
                  f"{row.get('candidates', 0):10.2f}")
    finally:
        sim.close()
    print(f"{'total':16s} {sums['plan']:6.2f} {sums.get('render', 0):7.2f} "
          f"{sums.get('forward', 0):8.2f} {sums['simulate']:9.2f} {sums.get('candidates', 0):10.2f}")


def costs(model, problem, ops) -> tuple[dict, float]:
    """(ms per operation of a forward pass by batch size, ms per operation of the inputs:
    rendering the images and, for a model that takes them, computing the descriptors)."""
    import numpy as np

    from rap.model.inference.operations import OperationPredictor

    cnn = OperationPredictor.load(model)
    cnn._inputs(problem, ops[:8])
    t = time.perf_counter()
    images, desc = cnn._inputs(problem, ops[:256])
    render = (time.perf_counter() - t) / len(images) * 1e3
    reps = 1 + 256 // len(images)
    images = np.concatenate([images] * reps)[:256]
    desc = None if desc is None else np.concatenate([desc] * reps)[:256]

    def forward(lo, hi):
        cnn._forward("expected_score", images[lo:hi], None if desc is None else desc[lo:hi])

    fwd = {}
    for b in BATCHES:  # the best of three passes over 256 images: this machine is shared
        forward(0, b)
        best = float("inf")
        for _ in range(3):
            n, t = 0, time.perf_counter()
            while n < 256:
                forward(n, n + b)
                n += b
            best = min(best, (time.perf_counter() - t) / n * 1e3)
        fwd[b] = best
    return fwd, render


def replay(graph, problem, pred, strategy):
    """(operations scored, batch sizes, best) of the bounded DP under a scoring order."""
    from rap.plan.dp import dp_choice_bounded

    key = problem.key
    known: set = set()
    batches: list[int] = []

    def score(subs):
        new = list(dict.fromkeys(key(o) for s in subs for o in graph[s] if key(o) not in known))
        if new:
            batches.append(len(new))
            known.update(new)

    def scores_of(s):
        if any(key(o) not in known for o in graph[s]):
            subs = [s]
            if strategy == "kids":
                for o in graph[s]:
                    subs += [c for c in (o.moving, o.fixed) if len(c) >= 2 and c not in subs]
            score(subs)
        return [pred[key(o)] for o in graph[s]]

    if strategy == "eager":
        score(list(graph))
    best, _ = dp_choice_bounded(graph, scores_of, problem.whole)
    return sum(batches), batches, best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*")
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    ap.add_argument("--dataset", default=str(ROOT / "datasets" / "unseen"),
                    help="simulator parameters and root seed (the unseen set's)")
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args()

    from rap.io import load_assembly
    from rap.experiment.run import dataset_params
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.graph import reachable

    folder = ROOT / "assemblies" / "unseen"
    names = args.names or sorted(p.stem for p in folder.glob("*.json"))
    assemblies = {n: load_assembly(folder / f"{n}.json") for n in names}
    params, seed = dataset_params(args.dataset)
    if not args.no_profile:
        profile(names, assemblies, params, seed, args.model)

    cnn = OperationPredictor.load(args.model)
    fwd = render = None
    totals: dict = {}
    print("\nbranch and bound replayed: operations scored, batches, model seconds (estimated)")
    for name in names:
        problem = PlanningProblem(assemblies[name], params, seed, "online")
        graph = reachable(problem, 20_000)
        ops = [op for c in graph.values() for op in c]
        if fwd is None:
            fwd, render = costs(args.model, problem, ops)
            print("forward ms/operation by batch: "
                  + ", ".join(f"{b}: {v:.2f}" for b, v in fwd.items())
                  + f"; inputs (images, descriptors) {render:.2f} ms/operation")
        pred = dict(zip((problem.key(o) for o in ops), cnn.expected_score(problem, ops)))
        line, best0 = [], None
        for strategy in ("lazy", "kids", "eager"):
            n, batches, best = replay(graph, problem, pred, strategy)
            best0 = best if best0 is None else best0
            assert best == best0, (name, strategy)
            cost = sum(b * fwd[max(x for x in BATCHES if x <= b)] for b in batches) + n * render
            t = totals.setdefault(strategy, [0, 0, 0.0])
            t[0] += n
            t[1] += len(batches)
            t[2] += cost / 1e3
            line.append(f"{strategy} {n:5d} {len(batches):4d} {cost / 1e3:5.2f}")
        print(f"{name:16s} " + " | ".join(line))
    print(f"{'total':16s} " + " | ".join(f"{s} {t[0]:5d} {t[1]:4d} {t[2]:5.2f}"
                                           for s, t in totals.items()))
    lazy = totals["lazy"][2]
    print("model time / lazy's: " + ", ".join(f"{s} {t[2] / lazy:.2f}" for s, t in totals.items()))


if __name__ == "__main__":
    main()
