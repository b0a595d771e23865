"""The paper's planning experiment: RAP vs the sim-only baseline vs the optimum vs random.

For each assembly of a labelled dataset, with a CNN that has not seen that assembly (a checkpoint
``MODELS/holdout-NAME.pt``, else ``MODELS/holdout-family-FAMILY.pt`` of a model that has not seen
the assembly's family, else trained here with ``rap.model.train.train(dataset, holdout=NAME)`` and
saved as the former), every method plans over the same operation space with the dataset's
simulator parameters and root seed (so the simulator's scores are the dataset's labels):

* each method's search runs with a COLD score cache (an empty ``ScoreCache``): no method looks fast
  because another one simulated its operations before; its wall time is ``PlanResult.seconds``;
* the returned sequence is then evaluated by the simulator (``robustness`` R); for ``random`` the
  figure is the mean R over ``samples`` random sequences.

``write_report`` writes ``results.md`` (a Markdown table and the headline ratios),
``results.json`` and ``scores.png`` (bars of R per assembly and method, like the paper's score
comparison figure, with planning times beside it).

No ray: the simulator backend is passed in (the command passes the Ray pool's ``PoolSimulator``).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from rap.errors import InputError
from rap.model.inference import PredictorCnn
from rap.plan.cache import ScoreCache
from rap.plan.methods import PAPER_RAP, make_planner
from rap.plan.problem import PlanningProblem
from rap.plan.result import PlanStatus
from rap.plan.scorers import Scorer, SimBackend

__all__ = ["ExperimentRow", "holdout_model", "run_experiment", "summarise", "write_report",
           "EXPERIMENT_METHODS"]

EXPERIMENT_METHODS = ("random", "rap", "sim", "optimal")


def method_planner(method: str, samples: int = 50):
    """The planner of a method name: one of ``EXPERIMENT_METHODS``, ``rap`` (its defaults,
    ``rap.plan.methods``) with options ``-kK`` (its fallback simulates at most the K candidates
    with the highest P(high)), ``-pP`` (a candidate is confidently high at P(high) >= P percent;
    default 90) and ``-oU`` (the fallback simulates best first, until the best simulated score
    exceeds the next candidate's expected score raised by U percent of its failure rate; default
    40; 100: all at once), ``rap-paper`` (the paper's rule, ``rap-p50-o100``), or ``search`` with options
    ``-wW`` (beam width W, used beyond the exact search's budget; ``-w`` alone with ``-b``:
    always the beam), ``-sN`` (N simulations while planning), ``-tP`` (operations predicted at
    P percent or more are trusted, not simulated), ``-oP`` (optimism P percent): e.g.
    ``search-w2-s10``, ``search-s100-t97``, ``search-s100-o40``."""
    if method == "search" or method.startswith("search-"):
        from rap.plan.search import DEFAULT_BEAM, DEFAULT_MAX_OPERATIONS, SearchPlanner

        opts = {"w": DEFAULT_BEAM, "s": 0, "b": DEFAULT_MAX_OPERATIONS, "t": None, "o": 0}
        for part in method.split("-")[1:]:
            key, val = part[:1], part[1:]
            if key not in opts or not val.isdigit():
                raise InputError(f"method {method!r}: search options are -wW, -sN, -bOPS, -tP, "
                                 f"-oP")
            opts[key] = int(val)
        if opts["w"] < 1 or opts["b"] < 1:
            raise InputError(f"method {method!r}: W and OPS must be >= 1")
        if opts["t"] is not None and not 0 < opts["t"] <= 100:
            raise InputError(f"method {method!r}: P must lie in 1..100")
        if opts["o"] > 100:
            raise InputError(f"method {method!r}: the optimism P must lie in 0..100")
        return SearchPlanner(beam_width=opts["w"], simulations=opts["s"], max_operations=opts["b"],
                             trust=None if opts["t"] is None else opts["t"] / 100,
                             optimism=opts["o"] / 100)
    if method == "rap-paper":  # the paper's rule: P(high) >= 0.5, every candidate simulated
        return make_planner("rap", **PAPER_RAP)
    if method.startswith("rap-"):
        opts = {"k": None, "p": None, "o": None}
        for part in method.split("-")[1:]:
            key, val = part[:1], part[1:]
            if key not in opts or not val.isdigit() or opts[key] is not None:
                raise InputError(f"method {method!r}: RAP options are -kK (an integer K), -pP "
                                 f"(a percentage P) and -oU (best-first fallback, optimism U "
                                 f"percent), as in rap-kK, rap-pP, rap-o10, rap-kK-pP")
            opts[key] = int(val)
        if opts["k"] is not None and opts["k"] < 1:
            raise InputError(f"method {method!r}: K must be >= 1")
        if opts["p"] is not None and not 0 < opts["p"] <= 100:
            raise InputError(f"method {method!r}: P must lie in 1..100")
        if opts["o"] is not None and opts["o"] > 100:
            raise InputError(f"method {method!r}: the optimism U must lie in 0..100")
        return make_planner("rap", fallback_k=opts["k"],
                            high_probability=None if opts["p"] is None else opts["p"] / 100,
                            fallback_optimism=None if opts["o"] is None else opts["o"] / 100)
    if method not in EXPERIMENT_METHODS:
        raise InputError(f"unknown method {method!r}: {', '.join(EXPERIMENT_METHODS)}, "
                         f"rap-paper, rap-kK-pP-oU or search-...")
    return make_planner(method, samples=samples)


def uses_cnn(method: str) -> bool:
    return method in ("rap", "search") or method.startswith(("rap-", "search-"))


@dataclass
class ExperimentRow:
    assembly: str
    method: str
    robustness: float | None
    seconds: float
    eval_seconds: float
    status: str
    simulations: int = 0
    fallbacks: int | None = None
    decisions: int | None = None
    extra: dict = field(default_factory=dict)


def holdout_model(dataset: str | Path, name: str, models_dir: str | Path, epochs: int = 8,
                  log: Callable[[str], None] = print, family: str | None = None) -> Path:
    """``models_dir/holdout-NAME.pt``, else ``models_dir/holdout-family-FAMILY.pt``; trained on
    ``dataset`` minus ``name`` (saved as the former) when neither exists."""
    path = Path(models_dir) / f"holdout-{name}.pt"
    if path.is_file():
        return path
    if family:
        fam = Path(models_dir) / f"holdout-family-{family}.pt"
        if fam.is_file():
            return fam
    from rap.model.train import TrainConfig, train

    log(f"training a CNN without {name} ({epochs} epochs) -> {path}")
    res = train(dataset, holdout=name, config=TrainConfig(epochs=epochs))
    return res.save(path)


def _params_and_seed(dataset: str | Path):
    from rap.dataset import read_meta
    from rap.sim.params import SimParams

    meta = read_meta(dataset)
    if meta is None:
        raise InputError(f"{dataset}: not a rap-farm dataset (no _rapfarm.json)")
    return SimParams.from_dict(dict(meta.params)), int(meta.root_seed)


def check_held_out(model: str | Path, assemblies: Sequence) -> None:
    """Raise ``InputError`` when the checkpoint ``model`` was trained on one of ``assemblies``
    (same geometry hash, from the checkpoint's metadata): the experiment measures held-out
    assemblies only."""
    meta = PredictorCnn.load(model, engine="auto").meta
    trained = set()
    for a in meta.get("assemblies") or []:
        h = a.get("geometry_hash")
        trained.update(h if isinstance(h, list) else [h])
    seen = [a.name for a in assemblies if a.geometry_hash in trained]
    if seen:
        raise InputError(f"--model {model}: trained on {', '.join(seen)}; the experiment needs "
                         f"assemblies the model has not seen (use --models for hold-out models)")


def run_experiment(dataset: str | Path, assemblies: Sequence, *, sim_backend: SimBackend,
                   models_dir: str | Path = "models", epochs: int = 8, trials: int | None = None,
                   methods: Sequence[str] = EXPERIMENT_METHODS, samples: int = 50,
                   log: Callable[[str], None] = print,
                   model: str | Path | None = None) -> list[ExperimentRow]:
    """Plan every assembly (``rap.assembly.Assembly`` objects named as in the dataset) with every
    method; see the module doc. ``trials`` overrides the dataset's trials per operation. With
    ``model``, that checkpoint scores every assembly (none of which it may have been trained on:
    ``check_held_out``) instead of one hold-out model per assembly."""
    params, root_seed = _params_and_seed(dataset)
    if trials is not None:
        params = params.with_(trials=int(trials))
    rows: list[ExperimentRow] = []
    for method in methods:
        method_planner(method, samples)  # unknown names fail before any work
    shared = None
    if model is not None and any(uses_cnn(m) for m in methods):
        check_held_out(model, assemblies)
        shared = PredictorCnn.load(model)  # loaded once for every assembly
    for asm in assemblies:
        cnn = None
        model_path = None
        if any(uses_cnn(m) for m in methods):
            if shared is not None:
                model_path, cnn = Path(model), shared
            else:
                model_path = holdout_model(dataset, asm.name, models_dir, epochs, log,
                                           family=getattr(asm, "family", None))
                cnn = PredictorCnn.load(model_path)
        for method in methods:
            problem = PlanningProblem(asm, params, root_seed, "online")
            scorer = Scorer(sim_backend, cnn if uses_cnn(method) else None, ScoreCache())  # cold
            if uses_cnn(method):  # warm the CNN and renderer up once (imports, first-call costs)
                scorer.cnn.prob_high(problem, list(problem.candidates(problem.whole))[:1])
            res = method_planner(method, samples).solve(problem, scorer)
            st = res.stats
            r = st.get("mean_robustness") if method == "random" else res.robustness
            cnn_method = uses_cnn(method)
            row = ExperimentRow(asm.name, method, r, res.seconds, res.eval_seconds,
                                res.status.value, int(st.get("sim_run", 0)),
                                st.get("fallbacks") if cnn_method else None,
                                st.get("decisions") if cnn_method else None,
                                {**{k: st[k] for k in ("exhaustive_sequences", "dp_evaluations",
                                                       "operations", "dp_speedup", "cnn_ops",
                                                       "fallback_candidates", "eval_simulations",
                                                       "search", "search_simulations",
                                                       "predicted_operations",
                                                       "predicted_robustness")
                                    if k in st},
                                 "family": getattr(asm, "family", None),
                                 "model": str(model_path) if cnn_method else None})
            rows.append(row)
            log(f"{asm.name:14s} {method:8s} R={'-' if r is None else f'{r:.4f}'} "
                f"plan {res.seconds:.2f} s, {row.simulations} simulations"
                + (f", {row.fallbacks}/{row.decisions} fallbacks" if row.decisions is not None else ""))
            if res.status is not PlanStatus.FOUND:
                log(f"  {res.status.value}: {res.message}")
    return rows


def _mean(xs):
    xs = [x for x in xs if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return sum(xs) / len(xs) if xs else float("nan")


def summarise(rows: Sequence[ExperimentRow]) -> dict:
    """Headline figures: mean R and time per method, sim/RAP time ratio, R differences, fallbacks."""
    by = {}
    for r in rows:
        by.setdefault(r.method, []).append(r)
    out: dict = {"methods": {}}
    for m, rs in by.items():
        out["methods"][m] = {"mean_robustness": _mean([r.robustness for r in rs]),
                             "mean_seconds": _mean([r.seconds for r in rs]),
                             "total_seconds": sum(r.seconds for r in rs)}
    if "rap" in by and "sim" in by:
        rap_t, sim_t = out["methods"]["rap"]["mean_seconds"], out["methods"]["sim"]["mean_seconds"]
        out["sim_over_rap_time"] = sim_t / rap_t if rap_t > 0 else float("inf")
        out["rap_minus_sim_robustness"] = (out["methods"]["rap"]["mean_robustness"]
                                           - out["methods"]["sim"]["mean_robustness"])
    out["versus_sim"] = {}
    if "sim" in by:
        sim = out["methods"]["sim"]
        for m in by:
            if m == "sim":
                continue
            mm = out["methods"][m]
            out["versus_sim"][m] = {
                "time_ratio": (sim["mean_seconds"] / mm["mean_seconds"]
                               if mm["mean_seconds"] > 0 else float("inf")),
                "robustness_difference": mm["mean_robustness"] - sim["mean_robustness"]}
    out["versus_optimal"] = {}
    if "optimal" in by:
        opt = {r.assembly: r for r in by["optimal"]}
        rap_t = {r.assembly: r.seconds for r in by.get("rap", [])}
        for m, rs in by.items():
            pairs = [(r, opt[r.assembly]) for r in rs if r.assembly in opt
                     and r.robustness is not None and opt[r.assembly].robustness]
            if not pairs:
                continue
            out["versus_optimal"][m] = {
                "robustness_fraction": _mean([r.robustness / o.robustness for r, o in pairs]),
                "time_fraction": _mean([r.seconds / o.seconds for r, o in pairs if o.seconds > 0]),
                "time_over_rap": _mean([r.seconds / rap_t[r.assembly] for r, _ in pairs
                                        if rap_t.get(r.assembly)]),
            }
    if "rap" in by and "optimal" in by:
        out["optimal_minus_rap_robustness"] = (out["methods"]["optimal"]["mean_robustness"]
                                               - out["methods"]["rap"]["mean_robustness"])
    if "rap" in by:
        out["rap_fallbacks"] = sum(r.fallbacks or 0 for r in by["rap"])
        out["rap_decisions"] = sum(r.decisions or 0 for r in by["rap"])
        out["rap_assemblies_with_fallback"] = sum(1 for r in by["rap"] if r.fallbacks)
    if "optimal" in by:
        opt = {r.assembly: r.robustness for r in by["optimal"]}
        worse = [f"{r.assembly}/{r.method}" for r in rows if r.method in ("rap", "sim")
                 and r.robustness is not None and opt.get(r.assembly) is not None
                 and r.robustness > opt[r.assembly] + 1e-12]
        out["optimal_beaten_by"] = worse  # must stay empty
    return out


def write_report(rows: Sequence[ExperimentRow], out_dir: str | Path, title: str,
                 notes: dict | None = None) -> list[Path]:
    """``results.md``, ``results.json`` and ``scores.png`` under ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(rows)
    names = list(dict.fromkeys(r.assembly for r in rows))
    methods = list(dict.fromkeys(r.method for r in rows))
    cell = {(r.assembly, r.method): r for r in rows}

    def fmt(x, spec=".3f"):
        return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)

    lines = [f"# {title}", ""]
    if notes:
        lines += [f"- {k}: {v}" for k, v in notes.items()] + [""]
    lines += ["## Robustness R (simulator) and planning time (s, cold score cache)", "",
              "| assembly | " + " | ".join(f"R {m}" for m in methods) + " | "
              + " | ".join(f"t {m}" for m in methods) + " | RAP fallbacks |",
              "|---" * (1 + 2 * len(methods) + 1) + "|"]
    for n in names:
        rr = [fmt(cell[(n, m)].robustness) if (n, m) in cell else "–" for m in methods]
        tt = [fmt(cell[(n, m)].seconds, ".2f") if (n, m) in cell else "–" for m in methods]
        fb = cell.get((n, "rap"))
        fbs = f"{fb.fallbacks}/{fb.decisions}" if fb and fb.decisions is not None else "–"
        lines.append(f"| {n} | " + " | ".join(rr) + " | " + " | ".join(tt) + f" | {fbs} |")
    ms = summary["methods"]
    lines.append("| **mean** | " + " | ".join(fmt(ms[m]["mean_robustness"]) for m in methods) + " | "
                 + " | ".join(fmt(ms[m]["mean_seconds"], ".2f") for m in methods) + " | |")
    lines += ["", "## Headline (ratios from this run)", ""]
    if "sim_over_rap_time" in summary:
        lines.append(f"- RAP is {summary['sim_over_rap_time']:.1f}x faster than the sim-only "
                     f"baseline (mean {ms['rap']['mean_seconds']:.2f} s vs "
                     f"{ms['sim']['mean_seconds']:.2f} s; paper: 9.1x, 2.38 s vs 21.58 s)")
        lines.append(f"- mean robustness RAP - sim = {summary['rap_minus_sim_robustness']:+.4f} "
                     f"(paper: -0.005)")
    if "optimal_minus_rap_robustness" in summary:
        lines.append(f"- optimal - RAP = {summary['optimal_minus_rap_robustness']:+.4f}; optimal is "
                     f"beaten by: {', '.join(summary['optimal_beaten_by']) or 'none (as it must)'}")
    if "rap_fallbacks" in summary:
        lines.append(f"- RAP fell back to the simulator at {summary['rap_fallbacks']} of "
                     f"{summary['rap_decisions']} decisions, in "
                     f"{summary['rap_assemblies_with_fallback']} of {len(names)} assemblies")
    opt_rows = [cell[(n, "optimal")] for n in names if (n, "optimal") in cell]
    if opt_rows and all("exhaustive_sequences" in r.extra for r in opt_rows):
        lines.append("- optimal by DP over subassemblies: "
                     + "; ".join(f"{r.assembly} {r.extra['dp_evaluations']} evaluations vs "
                                 f"{r.extra['exhaustive_sequences']:,} sequences"
                                 for r in opt_rows))
    if summary.get("versus_sim"):
        lines += ["", "## Robustness against planning time (means over the assemblies)", "",
                  "Per method: mean R; mean planning time; the sim-only baseline's time over the "
                  "method's; R minus the baseline's; and, per assembly then averaged, R as a "
                  "fraction of the optimum's, planning time as a fraction of the optimum's and "
                  "over greedy RAP's; the simulations of the searches (evaluation excluded).", "",
                  "| method | mean R | mean planning s | sim time / time | R - R sim | "
                  "R / R opt | t / t opt | t / t rap | simulations |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        vo = summary.get("versus_optimal", {})
        for m in methods:
            v = summary["versus_sim"].get(m, {"time_ratio": 1.0, "robustness_difference": 0.0})
            o = vo.get(m, {})
            sims = sum(r.simulations - int(r.extra.get("eval_simulations", 0)) for r in rows
                       if r.method == m)
            lines.append(f"| {m} | {fmt(ms[m]['mean_robustness'])} | "
                         f"{fmt(ms[m]['mean_seconds'], '.2f')} | {v['time_ratio']:.1f} | "
                         f"{v['robustness_difference']:+.4f} | "
                         f"{fmt(o.get('robustness_fraction'))} | {fmt(o.get('time_fraction'))} | "
                         f"{fmt(o.get('time_over_rap'), '.2f')} | {sims} |")
    md = out / "results.md"
    md.write_text("\n".join(lines) + "\n", encoding="utf-8")
    js = out / "results.json"
    js.write_text(json.dumps({"title": title, "notes": notes or {}, "summary": summary,
                              "rows": [r.__dict__ for r in rows]}, indent=2, default=str) + "\n",
                  encoding="utf-8")

    wide = 18 + 0.4 * max(0, len(names) - 12)
    fig, (ax, axt, axp) = plt.subplots(1, 3, figsize=(wide, 4.8),
                                       gridspec_kw={"width_ratios": [3, 2, 2]})
    labels = {"random": "random (mean of 50)", "rap": "RAP", "sim": "sim only", "optimal": "optimal"}
    cmap = plt.get_cmap("tab10" if len(methods) <= 10 else "tab20")
    color = {m: cmap(k % cmap.N) for k, m in enumerate(methods)}  # one colour per method
    width = 0.8 / max(1, len(methods))
    for k, m in enumerate(methods):
        xs = [i + (k - (len(methods) - 1) / 2) * width for i in range(len(names))]
        ax.bar(xs, [cell[(n, m)].robustness or 0.0 if (n, m) in cell else 0.0 for n in names],
               width, label=labels.get(m, m), color=color[m])
        axt.bar(xs, [cell[(n, m)].seconds if (n, m) in cell else 0.0 for n in names], width,
                label=labels.get(m, m), color=color[m])
    for a in (ax, axt):
        a.set_xticks(range(len(names)))
        a.set_xticklabels(names, rotation=35, ha="right", fontsize=8)
    ax.set_ylabel("robustness R")
    ax.set_ylim(0, 1.2)
    ax.legend(fontsize=8, loc="upper left", ncols=4, bbox_to_anchor=(0, 1.0), frameon=False)
    ax.set_title("Sequence robustness")
    axt.set_yscale("log")
    axt.set_ylabel("planning time (s, log)")
    axt.set_title("Planning time (cold cache)")
    points = sorted((ms[m]["mean_seconds"], ms[m]["mean_robustness"], m) for m in methods)
    for i, (t, r, m) in enumerate(points):
        if t == t and r == r:
            axp.scatter([t], [r], s=30, color=color[m])
            # neighbours in time alternate above and below their point, so labels do not collide
            axp.annotate(m, (t, r), textcoords="offset points", xytext=(4, 3 if i % 2 else -10),
                         fontsize=8)
    axp.set_xscale("log")
    plain = FuncFormatter(lambda v, _: f"{v:g}")  # 0.5, 1, 2, 5, 10 ... s: no crowded 2x10^0
    axp.xaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
    axp.xaxis.set_major_formatter(plain)
    axp.xaxis.set_minor_formatter(plain)
    axp.set_xlabel("mean planning time (s, log)")
    axp.set_ylabel("mean robustness R")
    axp.set_title("Robustness against planning time")
    fig.suptitle(title)
    fig.tight_layout()
    png = out / "scores.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return [md, js, png]
