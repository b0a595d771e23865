"""Sequential tests in the search, replayed on score tables: trials saved against plans changed.

Replays ``SearchPlanner`` with and without ``sequential`` (``research.variants.screening``) on the score
tables of ``research.search_validation`` (``research.validation_tables``: the model's expected
scores and every operation's 100-trial label). A REPLAY, not the simulator: a full simulation is
the table's label; a chunk of ``n`` trials is a binomial draw ``Binomial(n, label)`` from the
chunk's own seed (``rap.seeds.chunk_seed``), so chunks are as noisy as real ones would be if the
label were the true rate (it is itself a 100-trial estimate). Per assembly: trials simulated while
planning (full simulations x 100 + chunk trials), R (labels), R / R opt, whether the plan changed.

    python -m research.sequential_replay --set fresh --deltas 0.05,0.1,0.2   # choose (validation)
    python -m research.sequential_replay --set unseen --deltas 0.05          # report (test)

Settings: the planner is ``plan``'s default search (``SearchOptions``; ``--options upper=1.0,gap=0``
changes some) with ``--sequential D`` for each D of ``--deltas``; ``--chunks 20,20,20`` the
schedule (default: the library's, ``research.variants.sequential.DEFAULT_CHUNKS``). Cost: about a second
per (setting, assembly) on one core; nothing is simulated.
"""

from __future__ import annotations

import argparse
import math
import statistics

import numpy as np

from research.validation_tables import (ROOT, LookupCnn, LookupSimulator, assemblies_of,
                                        problem_of, saved_tables)


class BinomialChunks(LookupSimulator):
    """``LookupSimulator`` with chunks: ``Binomial(trials, label)`` from each chunk's seed."""

    def simulate_chunks(self, problem, chunks):
        from rap.plan.scoring.cache import CachedScore
        from rap.seeds import chunk_seed

        out = []
        for op, index, n in chunks:
            rng = np.random.default_rng(chunk_seed(problem.seed(op), index))
            s = int(rng.binomial(n, self.truth[problem.key(op)]))
            out.append(CachedScore(s / n, s, n))
        return out


def plan(tab: dict, problem, sequential: float | None, chunks: tuple[int, ...], bounds,
         **options):
    """The default search's plan on the table (``sequential``: its error rate, None: off;
    ``options``: other search options)."""
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.methods import make_planner
    from rap.plan.scoring.scorer import Scorer
    from research.variants.sequential import SequentialTest

    planner = make_planner("search", sequential=sequential, **options)
    planner.bounds = bounds
    if planner.sequential is not None:
        planner.sequential = SequentialTest(sequential, chunks)
    scorer = Scorer(BinomialChunks(tab["truth"]), LookupCnn(tab["pred"], tab.get("phigh")),
                    ScoreCache())
    result = planner.solve(problem, scorer)
    st = result.stats
    sims = int(st.get("sim_run", 0) - st.get("eval_simulations", 0))
    trials = sims * problem.params.trials + int(st.get("chunk_trials", 0))
    steps = tuple(sorted(problem.key(s.operation) for s in result.steps))
    r = math.prod(tab["truth"][problem.key(s.operation)] for s in result.steps)
    return {"R": r, "trials": trials, "sims": sims, "chunks": int(st.get("chunk_runs", 0)),
            "partial": int(st.get("search_partial", 0)), "steps": steps,
            "stopped": st.get("stopped")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("fresh", "unseen", "validation", "test"), default="fresh")
    ap.add_argument("--deltas", default="0.05")
    ap.add_argument("--chunks", default="", help="trials per chunk, e.g. 20,20,20 (default: "
                                                  "research.variants.sequential.DEFAULT_CHUNKS)")
    ap.add_argument("--only", default="")
    ap.add_argument("--options", default="", help="other search options, e.g. upper=1,gap=0")
    ap.add_argument("--cache", default=str(ROOT / "reports" / "search-validation"))
    a = ap.parse_args()
    from rap.model.calibration import load
    from rap.plan.dp import dp_choice
    from rap.plan.graph import reachable

    bounds = load()
    options = {k: float(v) if "." in v else int(v)
               for k, v in (x.split("=") for x in a.options.split(",") if x)}
    from research.variants.sequential import DEFAULT_CHUNKS

    chunks = tuple(int(x) for x in a.chunks.split(",")) if a.chunks else DEFAULT_CHUNKS
    deltas = [float(x) for x in a.deltas.split(",")]
    names = assemblies_of(a.set)
    if a.only:
        names = [n for n in names if n in a.only.split(",")]
    tabs = saved_tables(a.cache, a.set, names)
    print(f"{a.set}: {len(names)} assemblies, search {options or 'defaults'}, chunks {chunks} "
          f"(REPLAY: chunks are binomial draws from the 100-trial labels)")
    head = f"{'assembly':>16} {'R opt':>6} | {'off: R':>6} {'trials':>6}"
    for d in deltas:
        head += f" | {'q' + format(d, 'g') + ': R':>8} {'trials':>6} {'saved':>6} {'part':>4} chg"
    print(head)
    sums = {d: [] for d in deltas}
    for n in names:
        problem = problem_of(n)
        graph = reachable(problem)
        truth = tabs[n]["truth"]
        best, _ = dp_choice(graph, {s: [truth[problem.key(op)] for op in c]
                                    for s, c in graph.items()})
        opt = best[problem.whole]
        base = plan(tabs[n], problem, None, chunks, bounds, **options)
        line = f"{n:>16} {opt:6.3f} | {base['R']:6.3f} {base['trials']:6d}"
        for d in deltas:
            x = plan(tabs[n], problem, d, chunks, bounds, **options)
            changed = x["steps"] != base["steps"]
            saved = 1 - x["trials"] / base["trials"] if base["trials"] else 0.0
            sums[d].append((x["R"] / opt, base["R"] / opt, x["trials"], base["trials"], changed))
            line += (f" | {x['R']:8.3f} {x['trials']:6d} {saved:6.1%} {x['partial']:4d} "
                     f"{'yes' if changed else 'no':>3}")
        print(line, flush=True)
    for d in deltas:
        rows = sums[d]
        t, tb = sum(r[2] for r in rows), sum(r[3] for r in rows)
        print(f"q{d:g}: mean R/opt {statistics.mean(r[0] for r in rows):.4f} (off "
              f"{statistics.mean(r[1] for r in rows):.4f}); trials {t} against {tb} "
              f"({1 - t / tb:.1%} saved); plans changed {sum(r[4] for r in rows)} of {len(rows)}")


if __name__ == "__main__":
    main()
