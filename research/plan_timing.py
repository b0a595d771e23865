"""Real plans, timed: robustness against planning time for the old and new defaults and the optimum.

The score-table replays (``research.bound_coverage``) count simulations but time nothing. Here
every plan is made as ``rap-farm plan A.json --no-cache --seed SEED`` makes it, in this process:
the shipped model, a cold score cache, the simulator over forked worker processes
(``LocalSimulator``), so planning time includes rendering, the CNN, every simulation and the
search's bookkeeping. For each assembly the settings run one after another (so that they share the
machine's load), and ``R / R opt`` divides each plan's robustness by the optimum's at the same seed
(the optimal planner: every operation simulated, then dynamic programming). The simulator's scores
depend only on (operation, root seed), so the plans' steps and the optimum's are scored alike.

    python -m research.plan_timing [--assemblies assemblies/unseen] [--settings old,new,...]
        [--out reports/plan-timing/unseen.json] [--figure docs/figures/plan_time.png]

Settings: ``old`` (search, no simulations: the default before issue 30); ``new`` (the default
now); ``gG`` (the default with ``--gap G/100``: simulating on, by the bounds, until the plan is
within G% of the bound); ``bN`` (the default with ``--simulations N``), ``bN-gG`` (both); ``sim`` (simulator-only greedy); ``rap-paper``;
``optimal``. Results are kept per (assembly, setting) in ``--out`` and reused on a rerun, so an
interrupted run resumes (``--redo SETTINGS`` runs those again, e.g. on a quieter machine). Prints
the load average with each row: the times are this machine's (2 cores), under whatever else ran.

Cost: the optimum simulates every operation of the graph (about 13 a second on 2 cores).
"""

from __future__ import annotations

from research.figures import save_figure

import argparse
import json
import os
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SETTINGS = ("old", "b20", "b40", "new", "b20-g5", "b40-g5", "g5", "sim", "optimal")
SEED = 11


def options_of(setting: str) -> tuple[str, dict]:
    """(method, options) a setting name stands for (module doc)."""
    if setting == "old":
        return "search", {"simulations": 0}
    if setting == "rap-paper":
        from rap.plan.methods import PAPER_RAP

        return "rap", dict(PAPER_RAP)
    if setting in ("sim", "optimal"):
        return setting, {}
    options = {}
    for token in ([] if setting == "new" else setting.split("-")):
        if token[:1] == "b" and token[1:].isdigit():
            options["simulations"] = int(token[1:])
        elif token[:1] == "g" and token[1:].isdigit():
            options["gap"] = int(token[1:]) / 100
        else:
            raise ValueError(f"setting {setting!r}: old, new, bN, gG, bN-gG, sim, rap-paper or "
                             f"optimal")
    return "search", options


def plan_once(path: Path, setting: str, cnn, seed: int = SEED) -> dict:
    """One cold plan of ``path`` with ``setting``: robustness, planning seconds, simulations."""
    from rap.io import load_assembly
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.methods import make_planner
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.scorer import Scorer
    from rap.sim.params import SimParams

    method, options = options_of(setting)
    asm = load_assembly(path)
    sim = LocalSimulator(prestart=True)
    try:
        problem = PlanningProblem(asm, SimParams(), seed)
        if sim.prestarted:
            cnn.cores_busy = sim.loading
        t = time.perf_counter()
        problem.candidates(problem.whole)  # the NDBG, as plan builds it before planning
        ndbg = time.perf_counter() - t
        scorer = Scorer(sim, cnn if method != "sim" and method != "optimal" else None,
                        ScoreCache())
        render = cnn.render_seconds
        result = make_planner(method, **options).solve(problem, scorer)
        render = cnn.render_seconds - render
    finally:
        sim.close()
        cnn.cores_busy = None
    st = result.stats
    return {"robustness": result.robustness, "seconds": result.seconds, "ndbg_seconds": ndbg,
            # simulations while planning (the plan's evaluation simulates its unsimulated steps)
            "simulations": st.get("sim_run", 0) - st.get("eval_simulations", 0),
            "eval_simulations": st.get("eval_simulations", 0), "cnn_scores": st.get("cnn_ops", 0),
            # where the time went (seconds, planning and evaluation together): the CNN's calls
            # (rendering included), its rendering alone, the simulator's batches (waited for)
            "cnn_seconds": st.get("cnn_seconds", 0.0), "render_seconds": render,
            "sim_seconds": st.get("sim_seconds", 0.0),
            "bound": result.bound.get("robustness_upper") if result.bound else None,
            "load": os.getloadavg()[0]}


def run(paths: list[Path], settings: list[str], out: Path, redo: set[str]) -> dict:
    from rap.model.inference.operations import OperationPredictor

    data = json.loads(out.read_text()) if out.exists() else {}
    cnn = OperationPredictor.load(ROOT / "rap" / "data" / "default_model.pt", engine="auto")
    for path in paths:
        rows = data.setdefault(path.stem, {})
        for setting in settings:
            if setting in rows and setting not in redo:
                continue
            rows[setting] = plan_once(path, setting, cnn)
            r = rows[setting]
            print(f"{path.stem:16s} {setting:8s} R {r['robustness']:.3f}  {r['seconds']:7.2f} s  "
                  f"sims {r['simulations']:5d}  cnn {r['cnn_scores']:5d} ops {r['cnn_seconds']:6.2f} s "
                  f"(render {r['render_seconds']:5.2f} s)  sim batches {r['sim_seconds']:6.2f} s  "
                  f"load {r['load']:.1f}", flush=True)
            out.parent.mkdir(parents=True, exist_ok=True)
            tmp = out.with_suffix(".tmp")
            tmp.write_text(json.dumps(data, indent=1))
            tmp.replace(out)
    return data


def table(data: dict, settings: list[str]) -> str:
    """Markdown: per setting, mean R / R opt, worst, mean planning seconds, mean seconds / the
    optimum's, mean simulations."""
    lines = ["| setting | R / R opt | worst | planning s (mean) | time / optimum's (mean) | "
             "simulations (mean) |", "|---|---:|---:|---:|---:|---:|"]
    for s in settings:
        rows = [(d[s], d["optimal"]) for d in data.values() if s in d and "optimal" in d]
        if not rows:
            continue
        ratio = [r["robustness"] / o["robustness"] for r, o in rows if o["robustness"] > 0]
        tratio = [r["seconds"] / o["seconds"] for r, o in rows]
        lines.append(f"| {s} | {statistics.mean(ratio):.3f} | {min(ratio):.3f} | "
                     f"{statistics.mean(r['seconds'] for r, _ in rows):.2f} | "
                     f"{statistics.mean(tratio):.3f} | "
                     f"{statistics.mean(r['simulations'] for r, _ in rows):.1f} |")
    return "\n".join(lines)


def detail(data: dict, settings: list[str]) -> str:
    """Markdown, one row per assembly: the optimum's R and seconds, then per setting R / R opt,
    planning seconds and their ratio to the optimum's."""
    shown = [s for s in settings if s != "optimal"]
    head = "| assembly | R opt | optimum s | " + " | ".join(
        f"{s}: R/opt, s (x opt)" for s in shown) + " |"
    lines = [head, "|---|---:|---:|" + "---:|" * len(shown)]
    for name, d in data.items():
        if "optimal" not in d:
            continue
        o = d["optimal"]
        cells = [f"{d[s]['robustness'] / o['robustness']:.3f}, {d[s]['seconds']:.1f} "
                 f"({d[s]['seconds'] / o['seconds']:.2f})" if s in d else "" for s in shown]
        lines.append(f"| {name} | {o['robustness']:.3f} | {o['seconds']:.0f} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


STYLE = {"old": ("s", "tab:red", "old default (search, 0 simulations)"),
         "new": ("o", "black", "new default (bound search, 200 simulations at most)"),
         "g5": ("h", "tab:blue", "new default with --gap 0.05 (bound within 5%)"),
         "sim": ("D", "tab:green", "simulator-only greedy"),
         "rap-paper": ("v", "tab:purple", "greedy RAP, the paper's rule"),
         "optimal": ("*", "tab:gray", "optimum (every operation simulated)")}


def figure(data: dict, path: Path, settings: list[str]) -> None:
    """Two panels, R / R opt against simulations while planning and against planning seconds:
    each setting's mean (large marker; ``bN`` joined as the budget curve of the new default) over
    the assemblies that have the optimum, and each assembly's plan (small, faint)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    done = {a: d for a, d in data.items() if "optimal" in d and d["optimal"]["robustness"] > 0}
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), sharey=True)
    for ax, (key, label) in zip(axes, (("simulations", "simulations while planning"),
                                       ("seconds", "planning seconds (this 2-core machine)"))):
        means = {}
        for s in settings:
            rows = [(d[s], d["optimal"]) for d in done.values() if s in d]
            if not rows:
                continue
            xs = [max(r[key], 0.5) for r, _ in rows]
            ys = [r["robustness"] / o["robustness"] for r, o in rows]
            means[s] = (statistics.mean(xs), statistics.mean(ys))
            marker, color, _ = STYLE.get(s, ("o", "tab:blue", s))
            ax.plot(xs, ys, ls="", marker=marker, ms=3, color=color, alpha=0.25)
        for tail, head, color in (("", "new", "black"), ("-g5", "g5", "tab:blue")):
            budget = sorted((int(k[1:len(k) - len(tail)]), k) for k in means
                            if k.startswith("b") and k.endswith(tail)
                            and k[1:len(k) - len(tail)].isdigit())
            curve = [means[k] for _, k in budget] + ([means[head]] if head in means else [])
            if len(curve) > 1:
                ax.plot(*zip(*sorted(curve)), color=color, lw=0.8, marker="o", ms=3,
                        label=f"{STYLE[head][2].split(' (')[0]} at --simulations "
                              + ", ".join(str(n) for n, _ in budget) + " and 200")
        for s, (x, y) in means.items():
            if s in STYLE:
                marker, color, name = STYLE[s]
                ax.plot([x], [y], ls="", marker=marker, ms=9 if s != "optimal" else 12,
                        color=color, mfc="none" if s == "new" else color, label=name)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel(f"{label} (mean; log scale)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("R / R opt")
    axes[0].annotate("0 simulations drawn at 0.5", (0.5, 0), xycoords=("data", "axes fraction"),
                     xytext=(2, 3), textcoords="offset points", fontsize=6)
    axes[1].legend(fontsize=6.5, loc="lower right")
    fig.suptitle(f"real plans (--no-cache --seed {SEED}) on {len(done)} held-out assemblies: "
                 "robustness against simulations and time", fontsize=9)
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assemblies", default=str(ROOT / "assemblies" / "unseen"))
    ap.add_argument("--set", default="unseen",
                    help="only the assemblies of this score-table set (research.validation_tables: "
                         "the twelve of the replays); 'all': every file of --assemblies")
    ap.add_argument("--only", action="append", default=None, help="assembly names (repeatable)")
    ap.add_argument("--settings", default=",".join(DEFAULT_SETTINGS))
    ap.add_argument("--out", default=str(ROOT / "reports" / "plan-timing" / "unseen.json"))
    ap.add_argument("--detail", action="store_true", help="also print the per-assembly table")
    ap.add_argument("--figure", type=Path, help="also draw the figure (module doc) here")
    ap.add_argument("--redo", default="", help="settings to run again (comma-separated)")
    a = ap.parse_args()
    paths = sorted(Path(a.assemblies).glob("*.json"))
    if a.set != "all":
        from research.validation_tables import assemblies_of

        names = set(assemblies_of(a.set))
        paths = [p for p in paths if p.stem in names]
    if a.only:
        paths = [p for p in paths if p.stem in a.only]
    settings = a.settings.split(",")
    data = run(paths, settings, Path(a.out), set(filter(None, a.redo.split(","))))
    print(table(data, settings))
    if a.detail:
        print(detail(data, settings))
    if a.figure:
        figure(data, a.figure, settings)


if __name__ == "__main__":
    main()
