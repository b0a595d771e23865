"""The planning experiment's report: headline figures, a Markdown table, JSON and a chart.

``summarise(rows)`` gives the headline figures of ``rap.experiment.run.run_experiment``'s rows
(mean R and planning time per method, ratios against the sim-only baseline and the optimum, RAP's
fallbacks); ``write_report(rows, out_dir, title, notes)`` writes ``results.md`` (the tables and
the headline ratios), ``results.json`` (title, notes, summary, rows) and ``scores.png`` (bars of R
per assembly and method, like the paper's score comparison figure, planning times beside it, and
robustness against planning time). Rows are read by their fields only (``ExperimentRow``).

Matplotlib (Agg) is imported when a report is written. No ray, no torch.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:
    from rap.experiment.run import ExperimentRow

__all__ = ["summarise", "write_report"]


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
