"""Choose RAP's decision rule on held-out assemblies without timing anything.

Replays the greedy planners on ``research/search_validation.py``'s score tables (every operation of
an assembly's AND/OR graph with the model's P(high), its expected score and the simulator's score)
through the real ``RapPlanner`` and ``SimPlanner`` with look-up backends, and prints for each RAP
variant the mean robustness against simulator-only greedy's, the simulations it asked for and the
operations the CNN scored. Planning time is then priced from those counts by the per-operation
costs measured on this machine (``--sim-cost``, ``--cnn-cost``), which is how the variants compare
before a timed ``rap-farm experiment`` confirms the chosen one.

    python -m research.search_validation --set unseen          # builds the tables first (once)
    python -m research.rap_validation --set unseen --variants rap,rap-k1,rap-b10,rap-b20-p90
"""

from __future__ import annotations

import argparse
import math
import pickle
import statistics
import sys
from pathlib import Path

from research.validation_tables import ROOT, LookupCnn, LookupSimulator, assemblies_of, problem_of


def replay(name: str, tab: dict, method: str) -> dict:
    """Robustness (simulator scores) and counts of one greedy plan on the tables."""
    from rap.plan.scoring.cache import ScoreCache
    from rap.experiment.run import method_planner
    from rap.plan.scoring.scorer import Scorer

    problem = problem_of(name)
    scorer = Scorer(LookupSimulator(tab["truth"]), LookupCnn(tab["pred"], tab["phigh"]), ScoreCache(), free_by_geometry=False)
    result = method_planner(method).solve(problem, scorer)
    r = math.prod(tab["truth"][problem.key(s.operation)] for s in result.steps)
    st = result.stats
    return {"R": r, "sims": st.get("sim_run", 0) - st.get("eval_simulations", 0),
            "cnn": st.get("cnn_ops", 0), "fallbacks": st.get("fallbacks", 0),
            "decisions": st.get("decisions", 0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("validation", "test", "unseen", "fresh"), default="unseen")
    ap.add_argument("--variants", default="rap,rap-k1,rap-k2,rap-k3")
    ap.add_argument("--sim-cost", type=float, default=0.07,
                    help="seconds of planning per simulated operation (2 workers: 0.07)")
    ap.add_argument("--cnn-cost", type=float, default=0.003,
                    help="seconds per operation rendered and scored by the CNN")
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    ap.add_argument("--per-assembly", action="store_true")
    ap.add_argument("--round", type=int, help="candidates per subassembly per round of the "
                    "best-first fallback [default: rap.plan.planners.base.FALLBACK_ROUND]")
    a = ap.parse_args()
    if a.round is not None:
        import rap.plan.planners.base

        rap.plan.planners.base.FALLBACK_ROUND = a.round
    names = assemblies_of(a.set)
    tabs = pickle.loads((a.cache / f"{a.set}.pkl").read_bytes())
    missing = [n for n in names if n not in tabs or "phigh" not in tabs[n]]
    if missing:
        sys.exit(f"no tables with P(high) for {', '.join(missing)}: run "
                 f"python -m research.search_validation --set {a.set} first")
    base = {n: replay(n, tabs[n], "sim") for n in names}
    cost = lambda r: r["sims"] * a.sim_cost + r["cnn"] * a.cnn_cost  # noqa: E731
    t_sim = statistics.mean(cost(base[n]) for n in names)
    print(f"{a.set}: {len(names)} assemblies; sim-only greedy mean R {statistics.mean(base[n]['R'] for n in names):.3f}, "
          f"{statistics.mean(base[n]['sims'] for n in names):.1f} simulations, priced {t_sim:.2f} s")
    print(f"{'variant':>16} {'mean R':>7} {'R-Rsim':>7} {'worst':>7} {'sims':>6} {'cnn ops':>8} "
          f"{'fallbacks':>10} {'priced s':>8} {'speedup':>7}")
    for v in a.variants.split(","):
        res = {n: replay(n, tabs[n], v) for n in names}
        d = [res[n]["R"] - base[n]["R"] for n in names]
        t = statistics.mean(cost(res[n]) for n in names)
        fb = sum(res[n]["fallbacks"] for n in names)
        dec = sum(res[n]["decisions"] for n in names)
        print(f"{v:>16} {statistics.mean(res[n]['R'] for n in names):7.3f} {statistics.mean(d):+7.3f} "
              f"{min(d):+7.3f} {statistics.mean(res[n]['sims'] for n in names):6.1f} "
              f"{statistics.mean(res[n]['cnn'] for n in names):8.1f} {fb:>4}/{dec:<5} "
              f"{t:8.2f} {t_sim / t if t else math.inf:7.1f}", flush=True)
        if a.per_assembly:
            for n in names:
                print(f"    {n:>16} R {res[n]['R']:.3f} (sim {base[n]['R']:.3f}) sims {res[n]['sims']}")


if __name__ == "__main__":
    main()
