"""The bound-driven search on score tables: plan quality, simulations and the bound's coverage.

Replays ``SearchPlanner`` (and simulator-only greedy) on the score tables of
``research.search_validation`` (every operation's shipped-model expected score and simulated
score; the look-up backends of ``research.validation_tables``, so nothing is simulated here) and
compares each plan with the optimum (dynamic programming over the simulated scores):

* per setting: mean and worst R / R opt, simulations and model-scored operations a plan, and the
  bound ``V`` the plan reports: the fraction of assemblies with ``V >= R opt`` (coverage) and the
  mean gap ``1 - R / V``;
* per assembly (``--detail NAME,...``, settings by name): R opt, R, R / R opt, simulations, V,
  whether V covers the optimum, the gap.

    python -m research.search_validation --set fresh --trust none      # the tables, once
    python -m research.search_validation --set unseen --trust none
    python -m research.bound_coverage --set fresh                        # choose (validation)
    python -m research.bound_coverage --set unseen --detail old,b40-c95  # report (test)
    python -m research.bound_coverage --set unseen --figure docs/figures/bound_search.png
    python -m research.bound_coverage --set unseen --accuracy     # accuracy against the ceiling

Settings (``--settings``, comma-separated names; default: all below):

* ``old``: search as shipped before the bounds (no simulations); ``s200-o10``: ``--simulations
  200 --optimism 0.1``; ``sim``: simulator-only greedy;
* ``bN-cC[-gG][-tT][-uU][-oO][-aK][-p1]``: bound-driven search, ``--simulations N --upper U/100
  (default 1) --confidence C/100 [--gap G/100] [--trust T/100] [--optimism O/100]``, e.g.
  ``b40-c95-g5``; ``b200-c95-u0-o10`` is ``s200-o10``. With a gap the search goes on after its
  choice settles, by the bounds, until within the gap (``rap.plan.search.planner``, phase 2); ``-p1``:
  phase 1 only, the gap only stopping it earlier (what every gap setting meant before phase 2,
  e.g. ``b200-c95-g5-u35-p1``, the default's numbers before it). ``-aK``: the per-assembly
  score correction (``research.variants.score_correction``) with prior strength K. ``-p1`` and
  ``-aK`` were measured at commit 48873fe: the search lost those hooks in 0.3.0.

The bounds are ``--bounds`` (default the shipped ``rap/data/score_bounds.json``, fitted on the
``fresh`` set by ``research.score_bounds_calibration``: its coverage on ``fresh`` is in-sample,
on ``unseen`` out of sample). Results are also written to ``reports/bound-coverage/SET.json``
(``--figure`` draws from it). Cost: one replay per (setting, assembly), seconds each on 2 cores.
"""

from __future__ import annotations

from research.figures import save_figure

import argparse
import json
import math
import re
import statistics
import time
from pathlib import Path

from research.validation_tables import (ROOT, LookupCnn, LookupSimulator, assemblies_of,
                                        problem_of, saved_tables)

BUDGETS = (5, 10, 20, 40, 80, 200)
DEFAULT_SETTINGS = (["old", "s200-o10", "sim"]
                    + [f"b{n}-c{c}{g}" for c in (90, 95) for g in ("", "-g5", "-g10")
                       for n in BUDGETS]
                    + [f"b{n}-c95-t97" for n in BUDGETS] + [f"b{n}-c95-u50" for n in BUDGETS])
_BOUND = re.compile(r"^b(\d+)-c(\d+)(?:-g(\d+))?(?:-t(\d+))?(?:-u(\d+))?(?:-o(\d+))?"
                    r"(?:-a(\d+))?(-p1)?$")


def planner_of(setting: str, bounds):
    """The planner a setting name stands for (module doc)."""
    from rap.plan.planners.greedy import SimPlanner
    from rap.plan.search.planner import SearchPlanner

    if setting == "sim":
        return SimPlanner()
    if setting == "old":
        return SearchPlanner(simulations=0, bounds=bounds, upper=0.0)
    if setting == "s200-o10":
        return SearchPlanner(simulations=200, optimism=0.1, bounds=bounds, upper=0.0)
    m = _BOUND.match(setting)
    if m is None:
        raise ValueError(f"setting {setting!r}: old, s200-o10, sim or "
                         f"bN-cC[-gG][-tT][-uU][-oO][-aK][-p1]")
    n, c, g, t, u, o, a, p1 = m.groups()
    if a is not None or p1 is not None:
        raise ValueError(f"setting {setting!r}: -aK and -p1 name hooks removed from the search in "
                         f"0.3.0; their figures were measured at commit 48873fe (run this script "
                         f"from a worktree of it)")
    return SearchPlanner(simulations=int(n), confidence=int(c) / 100,
                         gap=None if g is None else int(g) / 100,
                         trust=None if t is None else int(t) / 100,
                         upper=1.0 if u is None else int(u) / 100,
                         optimism=0.0 if o is None else int(o) / 100, bounds=bounds)


def optimum(problem, graph, truth) -> float:
    """R opt: the DP over the simulated scores."""
    from rap.plan.dp import dp_choice

    best, _ = dp_choice(graph, {s: [truth[problem.key(op)] for op in c] for s, c in graph.items()})
    return best[problem.whole]


def replay(setting: str, name: str, tab: dict, bounds, problem, graph, best: float) -> dict:
    """One plan on the tables: its R against the optimum, its cost and its bound."""
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.scorer import Scorer

    scorer = Scorer(LookupSimulator(tab["truth"]), LookupCnn(tab["pred"], tab.get("phigh")),
                    ScoreCache())
    t = time.perf_counter()
    result = planner_of(setting, bounds).solve(problem, scorer)
    st = result.stats
    r = math.prod(tab["truth"][problem.key(s.operation)] for s in result.steps)
    v = None if result.bound is None else float(result.bound["robustness_upper"])
    return {"assembly": name, "setting": setting, "optimum": best, "R": r, "ratio": r / best,
            "simulations": int(st.get("sim_run", 0) - st.get("eval_simulations", 0)),
            "cnn_ops": int(st.get("cnn_ops", 0)),
            "operations": sum(len(c) for c in graph.values()),
            "V": v, "covered": None if v is None else bool(v >= best * (1 - 1e-12)),
            "gap": None if v is None else 1.0 - r / v, "stopped": st.get("stopped"),
            "replay_s": time.perf_counter() - t}


def summary(rows: list[dict]) -> dict:
    """Means over the assemblies of one setting."""
    bound = [x for x in rows if x["V"] is not None]
    return {"ratio": statistics.mean(x["ratio"] for x in rows),
            "worst": min(x["ratio"] for x in rows),
            "simulations": statistics.mean(x["simulations"] for x in rows),
            "sim_fraction": statistics.mean(x["simulations"] / x["operations"] for x in rows),
            "cnn_ops": statistics.mean(x["cnn_ops"] for x in rows),
            "coverage": statistics.mean(x["covered"] for x in bound) if bound else None,
            "gap": statistics.mean(x["gap"] for x in bound) if bound else None,
            "worst_gap": max(x["gap"] for x in bound) if bound else None,
            "at_least_sim": None}


def accuracy(tabs: dict, names) -> None:
    """The model's class accuracy (P(high) >= 0.5 against a score >= 0.95, as ``rap-farm score``)
    on every operation of each graph, beside the noise ceiling of those 100-trial scores
    (``rap.model.evaluation.metrics``); ``acc(p)``: the class of the expected score at 0.95 instead (as
    ``research.validation_tables.prediction_metrics``)."""
    import numpy as np

    from rap.model.evaluation.metrics import classification_metrics

    def row(keys_of):
        s = np.array([t for n in keys_of for t in tabs[n]["truth"].values()])
        ph = np.array([tabs[n]["phigh"][k] for n in keys_of for k in tabs[n]["truth"]])
        m = classification_metrics((s >= 0.95).astype(int), ph, np.rint(s * 100).astype(int),
                                   np.full(s.size, 100), reliability=False)
        p = np.array([tabs[n]["pred"][k] for n in keys_of for k in tabs[n]["truth"]])
        cut = float(np.mean((p >= 0.95) == (s >= 0.95)))  # prediction_metrics' accuracy
        return (f"{m['rows']:6d} {100 * m['accuracy']:6.1f} {100 * m['ceiling']:7.1f} "
                f"{m['accuracy'] / m['ceiling']:6.3f} {100 * m['ece']:5.1f} {100 * cut:8.1f} "
                f"{cut / m['ceiling']:6.3f}")

    print(f"{'assembly':>16} {'ops':>6} {'acc':>6} {'ceiling':>7} {'ratio':>6} {'ECE':>5} "
          f"{'acc(p)':>8} {'ratio':>6}")
    for n in names:
        print(f"{n:>16} {row([n])}")
    print(f"{'all':>16} {row(names)}")


CURVES = (("b{n}-c95", "upper 1 (branch and bound)", "tab:blue"),
          ("b{n}-c95-g5-u50", "upper 0.5, gap 5%", "tab:purple"),
          ("b{n}-c95-g5-u35", "upper 0.35, gap 5%", "tab:cyan"),
          ("b{n}-c95-u25", "upper 0.25", "tab:olive"))


def figure(results: dict, path: Path, chosen: str = "") -> None:
    """R / R opt against simulations a plan (budgets 5-200 along each curve, confidence 95%),
    one panel per set in ``results`` (set -> rows); ``chosen``: a setting to ring."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.4), squeeze=False)
    for ax, (set_name, rows) in zip(axes[0], results.items()):
        by = {}
        for x in rows:
            by.setdefault(x["setting"], []).append(x)
        s = {k: summary(v) for k, v in by.items()}
        ops = statistics.mean(x["operations"] for x in rows if x["setting"] == "sim")

        def pt(key, **kw):
            if key in s:
                ax.plot([max(s[key]["simulations"], 0.5)], [s[key]["ratio"]], ls="", **kw)

        for pattern, label, col in CURVES:
            keys = [pattern.format(n=n) for n in BUDGETS if pattern.format(n=n) in s]
            if keys:
                ax.plot([max(s[k]["simulations"], 0.5) for k in keys],
                        [s[k]["ratio"] for k in keys], marker="o", ms=3, color=col,
                        label=f"bound search, {label}")
        if chosen in s:
            pt(chosen, marker="o", ms=9, mfc="none", color="black",
               label=f"chosen default ({chosen})")
        pt("old", marker="s", color="tab:red", label="old default (search, 0 simulations)")
        pt("s200-o10", marker="^", color="tab:orange", label="--simulations 200 --optimism 0.1")
        pt("sim", marker="D", color="tab:green", label="simulator-only greedy")
        ax.plot([ops], [1.0], ls="", marker="*", ms=10, color="black",
                label="optimum (every operation simulated)")
        ax.set_xscale("log")
        ax.set_ylim(min(v["ratio"] for v in s.values()) - 0.02, 1.01)
        ax.set_xlabel("simulations a plan (mean)")
        ax.set_ylabel("R / R opt (mean)")
        ax.set_title(f"{set_name} ({len(by.get('sim', []))} assemblies)", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][-1].legend(fontsize=6, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.suptitle("plans on score tables: robustness against simulations spent while planning",
                 fontsize=9)
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("fresh", "unseen", "validation", "test"), default="fresh")
    ap.add_argument("--settings", default=",".join(DEFAULT_SETTINGS))
    ap.add_argument("--detail", default="", help="settings to print per assembly")
    ap.add_argument("--bounds", type=Path, help="score bounds file (default: the shipped one)")
    ap.add_argument("--only", default="", help="comma-separated assemblies of the set")
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    ap.add_argument("--out", type=Path, default=ROOT / "reports" / "bound-coverage")
    ap.add_argument("--figure", type=Path, help="draw R / R opt against simulations from the "
                                                "saved results of --figure-sets, write here")
    ap.add_argument("--figure-sets", default="fresh,unseen")
    ap.add_argument("--chosen", default="", help="the setting to ring in the figure")
    ap.add_argument("--saved", action="store_true",
                    help="no replay: print the tables from the rows saved by earlier runs")
    ap.add_argument("--accuracy", action="store_true",
                    help="only the model's class accuracy against the noise ceiling per assembly")
    a = ap.parse_args()
    if a.figure is not None:
        figure({s: json.loads((a.out / f"{s}.json").read_text())["rows"]
                for s in a.figure_sets.split(",")}, a.figure, a.chosen)
        return
    from rap.model.calibration import load
    from rap.plan.graph import reachable

    bounds = load(a.bounds)
    names = assemblies_of(a.set)
    if a.only:
        names = [n for n in names if n in a.only.split(",")]
    tabs = saved_tables(a.cache, a.set, names)
    if a.accuracy:
        accuracy(tabs, names)
        return
    settings = a.settings.split(",")
    print(f"{a.set}: {len(names)} assemblies; bounds {bounds.provenance.get('calibration', '?')}"
          f" ({bounds.provenance.get('model_sha256', '')[:12]})", flush=True)
    out = a.out / f"{a.set}.json"
    saved = json.loads(out.read_text())["rows"] if out.exists() else []
    if a.saved:  # no replay: the rows of earlier runs
        rows = [x for x in saved if x["setting"] in settings + ["sim"] and x["assembly"] in names]
    else:
        rows = []
        for n in names:
            problem = problem_of(n)
            graph = reachable(problem)
            best = optimum(problem, graph, tabs[n]["truth"])
            for s in settings:
                rows.append(replay(s, n, tabs[n], bounds, problem, graph, best))
            print(f"  {n}: {rows[-1]['operations']} operations, R opt {best:.3f}", flush=True)
    table = print_tables(rows, settings, filter(None, a.detail.split(",")))
    if a.saved:
        return
    a.out.mkdir(parents=True, exist_ok=True)
    done = {(y["setting"], y["assembly"]) for y in rows}
    out.write_text(json.dumps({"set": a.set, "bounds": bounds.provenance,
                               "rows": [x for x in saved if (x["setting"], x["assembly"])
                                        not in done] + rows, "summary": table}, indent=1))
    print(f"\nwrote {out}")


def print_tables(rows: list[dict], settings: list[str], detail) -> dict:
    """The summary table of ``settings`` (and the per-assembly rows of ``detail``); returns the
    summaries."""
    sim = {x["assembly"]: x["ratio"] for x in rows if x["setting"] == "sim"}
    print(f"\n{'setting':>16} {'R/R opt':>8} {'worst':>6} {'>=sim':>6} {'sims':>6} {'sims/ops':>8}"
          f" {'cnn ops':>8} {'V>=opt':>7} {'gap':>6} {'worst gap':>9}")
    table = {}
    for s in settings:
        rs = [x for x in rows if x["setting"] == s]
        sm = summary(rs)
        if sim:
            sm["at_least_sim"] = statistics.mean(x["ratio"] >= sim[x["assembly"]] - 1e-12
                                                 for x in rs)
        table[s] = sm
        f = (lambda v, w=6, d=3: f"{'-':>{w}}" if v is None else f"{v:{w}.{d}f}")
        print(f"{s:>16} {sm['ratio']:8.3f} {sm['worst']:6.3f} {f(sm['at_least_sim'])} "
              f"{sm['simulations']:6.1f} {sm['sim_fraction']:8.3f} {sm['cnn_ops']:8.0f} "
              f"{f(sm['coverage'], 7)} {f(sm['gap'])} {f(sm['worst_gap'], 9)}", flush=True)
    for s in detail:
        print(f"\n{s}: {'assembly':>16} {'ops':>5} {'R opt':>6} {'R':>6} {'R/opt':>6} {'sims':>5}"
              f" {'V':>6} {'V>=opt':>6} {'gap':>6} stopped")
        for x in (x for x in rows if x["setting"] == s):
            v = "-" if x["V"] is None else f"{x['V']:.3f}"
            g = "-" if x["gap"] is None else f"{x['gap']:.3f}"
            print(f"{'':>{len(s) + 1}} {x['assembly']:>16} {x['operations']:5d} {x['optimum']:6.3f}"
                  f" {x['R']:6.3f} {x['ratio']:6.3f} {x['simulations']:5d} {v:>6} "
                  f"{str(x['covered']):>6} {g:>6} {x['stopped']}")
    return table


if __name__ == "__main__":
    main()
