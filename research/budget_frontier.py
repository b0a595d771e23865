"""The default's simulation budget against R and time, on validation assemblies the benchmark lacks.

    python -m research.budget_frontier --band small [--assembly-seeds 2] [--jsonl rows.jsonl]
    python -m research.budget_frontier --band mid [--jsonl rows.jsonl]

``benchmarks/plan_scale.py`` measures the default at assembly seeds 0 and 1. This measures how
its budget options trade R for time on other assemblies of the same generators (other seeds and
sizes), so that a default is not chosen on the figures it is reported with:

* ``small`` (6-12 parts, below ``greedy_from``): the exact search's refine with its shipped budget
  (``base``: 200 simulations, ``upper`` 0.35), with a budget of 10% or 7% of the graph's
  operations (``s10``, ``s07``), with a lower or a higher bound share (``u25``, ``u20``; ``u50``,
  ``u60``), and simulating until within 5% of the bound on the optimum (issue 45, 3: ``g05``, the
  shipped budget; ``g05s600``, three times it), and the shipped search with the CNN alone
  (``cnn``: issue 45 asks the default never more than 0.03 below it), against the optimum (every
  operation simulated): R / optimum's R and time / optimum's time;
* ``mid`` (18-24 parts): ``improve`` 0.5, 0.75, 1 (shipped) and 1.5 after greedy's start, and 1
  with ``upper`` 0.5 (``u50``), and the exact search without the start (``nostart``,
  ``greedy_from`` past the parts: the previous default's search with this scorer), and the shipped
  search with the CNN alone as its scorer (``cnn``: issue 45 asks the default's R to be no lower
  than it there), and the shipped search with the guard acting on every assembly (``l2``: its
  action, the larger of the trees' and the CNN's numbers until the seventh session, their mean
  since; ``budget_frontier.mid_l2.jsonl`` holds the larger), against simulator-only greedy.
  ``--detectors``: per mid assembly, the guard's two candidate signals (``detectors``), no
  planning.

Planning seed 11, 100 trials, the default scorer, simulations in this process, back to back on
each assembly (ratios within one run). Each row is printed (and appended to ``--jsonl``) as it
ends, then the summary per setting. Cost: ``small`` about 25 minutes (the optima), ``mid`` about
15 minutes, on one core.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import time

from benchmarks.plan_scale import _graph_operations, build
from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor
from rap.plan import plan
from rap.sim.params import SimParams

SMALL = {"herringbone": (7, 9, 11), "wall": (7, 12), "grid": (6, 9, 12), "convex": (9, 12),
         "tiling": (8, 11), "polyomino": (8, 10, 12), "knobs": (7, 10), "packing": (8, 11)}
#: (kind, parts, assembly seed): walls and grids are the same at every seed
MID = [("herringbone", 18, 2), ("herringbone", 20, 3), ("polyomino", 20, 2),
       ("polyomino", 18, 3), ("packing", 24, 2), ("packing", 20, 3), ("convex", 20, 2),
       ("tiling", 22, 2), ("wall", 20, 0), ("grid", 20, 0), ("knobs", 20, 2)]
SEED = 11


def _settings(band: str, ops: int | None) -> dict[str, dict]:
    if band == "small":
        return {"base": {}, "s10": {"simulations": max(1, -(-ops * 10 // 100))},
                "s07": {"simulations": max(1, -(-ops * 7 // 100))},
                "u25": {"upper": 0.25}, "u20": {"upper": 0.2},
                "u50": {"upper": 0.5}, "u60": {"upper": 0.6},
                "g05": {"gap": 0.05}, "g05s600": {"gap": 0.05, "simulations": 600},
                "cnn": {"engine": "cnn"}}
    return {"i050": {"improve": 0.5}, "i075": {"improve": 0.75}, "i100": {},
            "i150": {"improve": 1.5}, "nostart": {"greedy_from": 1000},
            "u50": {"upper": 0.5},
            "cnn": {"engine": "cnn"}, "l2": {"engine": "guarded"}}


def _plan(asm, method, model, params, **options) -> list:
    r = plan(asm, method, model=model, seed=SEED, params=params, **options)
    return [r.robustness, r.seconds, r.stats.get("sim_run", 0)]


@functools.lru_cache(maxsize=1)
def _cnn_alone():
    """The shipped CNN without the descriptor model (the ``cnn`` setting), loaded once."""
    return OperationPredictor.load(SHIPPED_MODEL, engine="cnn")


@functools.lru_cache(maxsize=1)
def _guard_everywhere():
    """The shipped cascade with its guard flagging every assembly (the ``l2`` setting): every
    operation scored by the trees and the CNN and combined, as on an unfamiliar one."""
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    model.guard.share = -1.0
    return model


def detectors(model, asm) -> dict:
    """What the guard's two candidate signals say of ``asm`` (planning seed ``SEED``): the share
    of its sampled operations beyond the familiarity limit (flagged above ``share``), and the mean
    and largest ``|CNN - trees|`` expected score on the same sample."""
    import numpy as np

    from rap.model.inference.cascade import GUARD_OPERATIONS, guard_sample
    from rap.plan.problem import PlanningProblem

    problem = PlanningProblem(asm, SimParams(), SEED)
    verdict = model.verdict(problem)
    ops = guard_sample(problem, GUARD_OPERATIONS)
    d = model.descriptors(problem, ops)
    trees = model.model.prob_high_and_expected(d)[1]
    cnn = model.cnn.expected_score(problem, ops)
    gap = np.abs(np.asarray(cnn) - trees)
    return {"outside": verdict["outside"], "share": verdict["share"],
            "disagreement_mean": round(float(gap.mean()), 4),
            "disagreement_max": round(float(gap.max()), 4)}


def rows_for(band: str, seeds: list[int], model, params, only: list[str] | None = None):
    """Yield one row per validation assembly (module doc); ``only``: these settings (None:
    all)."""
    cases = ([(k, n, s) for s in seeds for k, ns in SMALL.items() for n in ns]
             if band == "small" else MID)
    for kind, n, aseed in cases:
        try:
            asm = build(kind, n, aseed)
        except ValueError as exc:
            print(f"{kind} {n}: skipped ({exc})", flush=True)
            continue
        row = {"kind": kind, "parts": n, "assembly_seed": aseed}
        if band == "small":
            row["operations"] = ops = _graph_operations(asm, SEED, params, 3000)
            if ops is None:
                print(f"{kind} {n}: skipped (over 3,000 operations, no optimum)", flush=True)
                continue
            row["reference"] = _plan(asm, "optimal", model, params)
        else:
            ops = None
            row["reference"] = _plan(asm, "sim", model, params)
        for name, options in _settings(band, ops).items():
            if only and name not in only:
                continue
            options = dict(options)
            engine = options.pop("engine", None)
            chosen = {"cnn": _cnn_alone, "guarded": _guard_everywhere}.get(engine, lambda: model)()
            row[name] = _plan(asm, "search", chosen, params, **options)
        yield row


def summary(rows: list[dict], band: str) -> list[str]:
    """Per setting: R and time over the reference's (the optimum or greedy), as printed."""
    def gmean(xs):
        return math.exp(sum(math.log(x) for x in xs) / len(xs))

    out = []
    for name in [n for n in _settings(band, 100) if rows and n in rows[0]]:
        rs = [r[name][0] / r["reference"][0] for r in rows if r["reference"][0] > 0]
        ts = [r[name][1] / r["reference"][1] for r in rows]
        line = (f"{name:8s} R/ref min {min(rs):.3f} mean {sum(rs) / len(rs):.3f} "
                f"(below 0.95: {sum(x < 0.95 for x in rs)} of {len(rs)}) | time/ref max "
                f"{max(ts):.2f} geometric mean {gmean(ts):.3f}")
        if band == "mid" and "nostart" in rows[0]:
            ns = [r[name][0] / r["nostart"][0] for r in rows if r["nostart"][0] > 0]
            line += f" | R/nostart geometric mean {gmean(ns):.3f} min {min(ns):.3f}"
        out.append(line)
    return out


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--band", choices=("small", "mid"), required=True)
    ap.add_argument("--assembly-seeds", default="2", help="comma-separated (small band)")
    ap.add_argument("--jsonl", default=None, help="append each row to this file")
    ap.add_argument("--settings", default="", help="comma-separated (default: every setting)")
    ap.add_argument("--detectors", action="store_true",
                    help="mid band: the guard's signals per assembly only, no planning")
    a = ap.parse_args(argv)
    model = OperationPredictor.load(SHIPPED_MODEL, engine="auto")
    if a.detectors:
        rows = [{"kind": k, "parts": n, "assembly_seed": s, **detectors(model, build(k, n, s))}
                for k, n, s in MID]
        print("\n".join(json.dumps(r) for r in rows))
        return rows
    params = SimParams()
    plan(build("grid", 4), "search", model=model, seed=SEED, params=SimParams(trials=2))  # warm
    reference = "optimum" if a.band == "small" else "greedy"
    print(f"budget_frontier {a.band}: R and time over the {reference}'s; {time.ctime()}")
    rows = []
    only = [s for s in a.settings.split(",") if s] or None
    for row in rows_for(a.band, [int(s) for s in a.assembly_seeds.split(",")], model, params,
                        only):
        rows.append(row)
        print(json.dumps(row), flush=True)
        if a.jsonl:
            with open(a.jsonl, "a") as fh:
                fh.write(json.dumps(row) + "\n")
    print("\n".join(summary(rows, a.band)))
    return rows


if __name__ == "__main__":
    main()
