"""What ``rap-farm plan`` (and ``demo``) make of a plan: the ``--out`` document and the ``--csv``
table (``rap.plan.report.poses.CSV_COLUMNS``), both written atomically with the umask's mode, and the
table printed with insertion directions, score intervals, reasons, R, timings and the planner's
counters."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

from rap.errors import InputError
from rap.files import write_text_atomic

__all__ = ["write_plan_json", "write_plan_csv", "write_outputs", "print_result", "interval_text",
           "bound_lines"]


def write_plan_json(result, path: Path) -> Path:
    """Write ``result.to_json()`` (the one serialiser of a plan, also the planning service's answer)
    atomically with the umask's mode (``rap.files.write_text_atomic``)."""
    path = Path(path)
    try:
        return write_text_atomic(path, json.dumps(result.to_json(), indent=2) + "\n")
    except OSError as exc:
        raise InputError(f"--out {path}: cannot write ({exc.strerror or exc})") from None


def write_plan_csv(result, path: Path) -> Path:
    """Write a found plan's steps as CSV (header ``CSV_COLUMNS``, one row per step, assembly
    order; ``rap.plan.report.poses.plan_rows``), atomically with the umask's mode."""
    from rap.plan.report.poses import CSV_COLUMNS, plan_rows

    path = Path(path)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(plan_rows(result))
    try:
        return write_text_atomic(path, buf.getvalue(), newline="")
    except OSError as exc:
        raise InputError(f"--csv {path}: cannot write ({exc.strerror or exc})") from None


def write_outputs(console, assembly, result, *, out=None, csv=None, picture=None) -> None:
    """A found plan's ``--out`` JSON, ``--csv`` steps and ``--picture`` storyboard (R and its
    interval in the title), each announced on ``console``."""
    if out is not None:
        console.print(f"plan written to {write_plan_json(result, out)}")
    if csv is not None:
        console.print(f"steps written to {write_plan_csv(result, csv)}")
    if picture is not None:
        from rap.render.pictures import storyboard

        ci = "" if result.robustness_interval is None else \
            f" {interval_text(result.robustness_interval, 3)}"
        path = storyboard(assembly, result.steps, picture, title=f"{assembly.name}: "
                          f"{result.method}, R = {result.robustness:.3f}{ci}")
        console.print(f"storyboard written to {path}")


def interval_text(lo_hi, digits: int = 2) -> str:
    """``[lo, hi]`` as text ("" when unknown)."""
    return "" if lo_hi is None else f"[{lo_hi[0]:.{digits}f}, {lo_hi[1]:.{digits}f}]"


def bound_lines(result) -> list[str]:
    """The plan's bound on the optimum (``PlanResult.bound``) and how the search stopped, in
    words; none for a method without a bound."""
    b, st = result.bound, result.stats
    if not b:
        return []
    v, gap = b["robustness_upper"], b["gap"]
    out = [f"optimum <= {v:.4f} at {100 * b['confidence']:g}% confidence: this plan has at least "
           f"{100 * (1 - gap):.1f}% of the optimum's robustness (gap {100 * gap:.1f}%)"
           + (f" ({b['note']})" if b.get("note") else "")]
    n = st.get("stopped_after", 0)
    if st.get("stopped") == "gap":
        out.append(f"stopped at --gap {st['gap']:g} after {n} simulations")
    elif st.get("stopped") == "bound":
        out.append(f"stopped after {n} simulations: no sequence left can beat this plan at the "
                   f"bounds' confidence")
    elif st.get("stopped") == "budget" and "phase2_simulations" in st:
        out.append(f"the budget ran out after {n} simulations, {st['phase2_simulations']} of "
                   f"them after the choice settled, before --gap {st['gap']:g} was reached")
    elif st.get("stopped") == "time":
        out.append(f"--time-limit reached: the plan is the best by what was known after "
                   f"{st.get('search_simulations', 0)} simulations")
    return out


def print_result(console, result, *, wall_s: float | None = None, title: str | None = None,
                 ray: bool = False) -> None:
    """The sequence as a rich table, R and timings."""
    from rich.table import Table

    from rap.plan.report.result import PlanStatus

    if result.status is not PlanStatus.FOUND:
        console.print(f"[bold red]{result.status.value}[/]: {result.message}")
        return
    table = Table(title=title or f"{result.assembly}: {result.method} plan "
                                 f"({len(result.steps)} steps, assembly order)")
    level = f"{100 * result.confidence_level:.0f}% CI" if result.confidence_level else "CI"
    cnn = any(s.confidence is not None for s in result.steps)  # P(high) only where the CNN chose
    ex = any(s.execution is not None for s in result.steps)  # format 3: measured by rollouts
    for col, kw in (("step", {"justify": "right"}), ("moving", {"overflow": "fold"}), ("fixed", {"overflow": "fold"}),
                    ("insertion", {"no_wrap": True}), ("score", {"justify": "right"}),
                    (level, {"no_wrap": True}), ("chosen by", {}),
                    *((("P(high)", {"justify": "right"}),) if cnn else ()),
                    *((("tol. mm", {"justify": "right"}),) if ex else ()),
                    ("limited by", {"overflow": "fold"})):
        table.add_column(col, **kw)
    for i, s in enumerate(result.steps, 1):
        bad = s.score is not None and s.score < 0.95
        score = "?" if s.score is None else f"{s.score:.3f}"
        table.add_row(str(i), ",".join(s.moving), ",".join(s.fixed),
                      f"({s.direction[0] + 0.0:+.3f},{s.direction[1] + 0.0:+.3f})",
                      f"[red]{score}[/]" if bad else score, interval_text(s.score_interval),
                      s.source, *(("" if s.confidence is None else f"{s.confidence:.3f}",)
                                  if cnn else ()), *(_executed(s) if ex else ()), s.reason or "")
    console.print(table)
    st = result.stats
    free = sum(s.source == "free" for s in result.steps)  # 1 by geometry, not simulated
    line = f"robustness R = {result.robustness:.4f} (product of the simulator's step scores"
    if free:
        line = (f"robustness R = {result.robustness:.4f} (product of the step scores: {free} free "
                f"by geometry, exactly 1" + (", the rest the simulator's" if free < len(
                    result.steps) else ""))
    if result.robustness_interval is not None and free < len(result.steps):
        line += (f"; {level} {interval_text(result.robustness_interval, 3)} from "
                 f"{result.trials} trials a step, Bonferroni")
    line += ")"
    if result.method == "random" and "mean_robustness" in st:
        line += (f"; mean over {st['samples']} random sequences = {st['mean_robustness']:.4f} "
                 f"(shown: the sample closest to the mean)")
    console.print(line)
    if result.expected_failures is not None and result.steps:  # beside R: where it fails
        weak = ", ".join(f"{i} ({result.steps[i - 1].score:.3f})" for i in result.weakest_steps())
        tries = result.expected_attempts  # retrying a failed step: the sum of 1/r
        console.print(f"expected failed steps: {result.expected_failures:.2f} of "
                      f"{len(result.steps)}; expected attempts with retries: "
                      + (f"{tries:.2f}" if math.isfinite(tries) else "unbounded (a step scores 0)")
                      + (f"; weakest: step {weak}" if weak else ""))
    for text in sequence_lines(result):
        console.print(text)
    if st.get("constraints"):
        from rap.plan.cell.constraints import CellConstraints

        console.print(f"cell: {CellConstraints.from_json(st['constraints']).describe()}; "
                      f"{st.get('score_note', '')}")
    if st.get("guard"):  # the default scorer found the assembly unfamiliar and acted
        g = st["guard"]
        console.print(f"unfamiliar assembly: {g.get('outside', 0):.0%} of {g.get('operations')} "
                      f"sampled operations lie far from the training data (flagged beyond "
                      f"{g.get('share', 0):.0%}): {g.get('action', '')}")
    for text in bound_lines(result):
        console.print(text)
    parts = [f"planning {result.seconds:.2f} s", f"evaluation {result.eval_seconds:.2f} s"]
    if wall_s is not None:
        parts.append(f"wall {wall_s:.2f} s" + (" (reading the assembly and Ray start-up included)"
                                               if ray else " (reading the assembly included)"))
    if st.get("service_seconds") is not None and not ray:
        parts.append(f"service {st['service_seconds']:.2f} s")
    console.print("time: " + ", ".join(parts))
    facts = [f"{st.get('sim_run', 0)} simulations run", f"{st.get('cache_hits', 0)} cached scores used"]
    if st.get("free"):
        facts.append(f"{st['free']} scores of free operations (no contact: 1 without simulation)")
    if st.get("cnn_batches"):
        facts.append(f"{st['cnn_ops']} CNN scores in {st['cnn_batches']} batches")
    if result.method == "rap":
        facts.append(f"simulator fallbacks: {st.get('fallbacks', 0)} of {st.get('decisions', 0)} "
                     f"decisions")
    if result.method == "search" and st.get("search"):  # a single part: no search
        how = (f"exact DP over {st.get('operations', '?')} operations" if st.get("search") == "exact"
               else f"beam of width {st.get('beam_width')}")
        start = (f"from simulator-only greedy's plan (R {st['greedy_robustness']:.3g}, "
                 f"{st.get('greedy_simulations', 0)} simulations), "
                 if st.get("greedy_robustness") is not None else "")
        facts.append(f"search: {how}, {start}{st.get('predicted_operations', 0)} operations "
                     f"scored by the model, {st.get('search_simulations', 0)} simulated while "
                     f"improving" if start else
                     f"search: {how}, {st.get('predicted_operations', 0)} operations scored by "
                     f"the model, {st.get('search_simulations', 0)} simulated while planning")
    if result.method == "optimal" and "subassemblies" in st:
        facts.append(f"DP over {st['subassemblies']} subassemblies / {st['operations']} operations "
                     f"vs. {st['exhaustive_sequences']:,} sequences for an exhaustive search "
                     f"({st['dp_speedup']:.0f}x fewer step evaluations)")
    console.print("; ".join(facts))
    if result.steps and result.steps[0].robot is not None:
        units = "units" if result.units == "unit" else result.units
        console.print(f"insertion = the direction the moving parts travel to their place "
                      f"(removal = -insertion); poses and travel in {units}: see --out / --csv",
                      style="dim")


def _executed(step) -> tuple[str]:
    """A step's rollout column: its tolerance (red: below the cell's error budget; its success
    once reached is in the JSON and the CSV)."""
    e = step.execution
    if e is None or e.tolerance_mm is None:
        return ("",)
    tol = f"{e.tolerance_mm:.2g}"
    return (f"[red]{tol}[/]" if e.below_budget else tol,)


#: what became of ``--perturbed-candidate`` when it is not among the candidates (the search's
#: ``perturbed_outcome``, ``rap.plan._with_perturbed``)
_PERTURBED_FATE = {"duplicate": "is one of the search's own",
                   "none": "does not exist: no sequence succeeded from perturbed starts",
                   "too large": "was not sought: the graph has over {limit:,} operations",
                   "over budget": "was not finished within the budget (the counts simulated "
                                  "are in the score cache for the next run)"}


def _perturbed_cost(stats: dict) -> str:
    """``N operations simulated`` (``, M from the score cache`` where it held some)."""
    cached = stats.get("perturbed_cached", 0)
    return (f"{stats.get('perturbed_simulated', '?')} operations simulated"
            + (f", {cached} from the score cache" if cached else ""))


def sequence_lines(result) -> list[str]:
    """What the rollouts measured (plan format 3): the sequence success beside R, how the plan
    was chosen, and the steps whose tolerance is below the cell's error budget."""
    seq = result.sequence
    if seq is None:
        return []
    errs = seq.errors
    lines = [f"{seq.text()} under the cell's errors (grasp +-{errs.get('grasp_across_mm', 0):g} "
             f"mm across, +-{errs.get('grasp_along_mm', 0):g} along, "
             f"+-{errs.get('grasp_angle_deg', 0):g} deg; arm {errs.get('repeatability_mm', 0):g} "
             f"mm), each step from where the earlier ones left the parts"]
    if len(seq.candidates) > 1:
        others = [c for c in seq.candidates if not c["chosen"]]
        best = max(c["rate"] for c in others)
        pert = sum(bool(c.get("perturbed_starts")) for c in seq.candidates)
        whose = ("plans of the search" if not pert else
                 f"plans (the search's {len(seq.candidates) - pert} and the best on perturbed-start "
                 f"scores: {_perturbed_cost(result.stats)})")
        lines.append(f"chosen by sequence success among {len(seq.candidates)} {whose} "
                     + ("(its best product)" if seq.candidates[0]["chosen"] else
                        f"(the best product measured {seq.candidates[0]['rate']:.3f})")
                     + f"; the best other measured {best:.3f}")
    fate = _PERTURBED_FATE.get(result.stats.get("perturbed_outcome"))
    if fate:
        from rap.plan.execution import PERTURBED_MAX_OPERATIONS

        fate = fate.format(limit=PERTURBED_MAX_OPERATIONS)
        lines.append(f"the best plan on perturbed-start scores {fate} "
                     f"({_perturbed_cost(result.stats)})")
    flagged = [i for i, s in enumerate(result.steps, 1)
               if s.execution is not None and s.execution.below_budget]
    if flagged:
        lines.append(f"tolerance below the cell's error budget "
                     f"(+-{errs.get('grasp_across_mm', 0) + errs.get('repeatability_mm', 0):g} mm "
                     f"across): step " + ", ".join(
                         f"{i} ({result.steps[i - 1].execution.tolerance_mm:g} mm)"
                         for i in flagged))
    return lines
