"""What ``rap-farm plan`` (and ``demo``) make of a plan: the ``--out`` document, written
atomically, and the table printed with R, timings and the planner's counters."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from rap.errors import InputError

__all__ = ["write_plan_json", "print_result"]


def write_plan_json(result, path: Path) -> Path:
    """Write ``result.to_json()`` (the one serialiser of a plan, also the planning service's answer)
    atomically: temporary file + rename."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".json", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(result.to_json(), fh, indent=2)
            fh.write("\n")
        os.replace(tmp, path)
    except OSError as exc:
        raise InputError(f"--out {path}: cannot write ({exc.strerror or exc})") from None
    return path


def print_result(console, result, *, wall_s: float | None = None, title: str | None = None,
                 ray: bool = False) -> None:
    """The sequence as a rich table, R and timings."""
    from rich.table import Table

    from rap.plan.result import PlanStatus

    if result.status is not PlanStatus.FOUND:
        console.print(f"[bold red]{result.status.value}[/]: {result.message}")
        return
    table = Table(title=title or f"{result.assembly}: {result.method} plan "
                                 f"({len(result.steps)} steps, assembly order)")
    for col, kw in (("step", {"justify": "right"}), ("moving", {"overflow": "fold"}), ("fixed", {"overflow": "fold"}),
                    ("direction", {"no_wrap": True}), ("score", {"justify": "right"}), ("chosen by", {}),
                    ("P(high)", {"justify": "right"})):
        table.add_column(col, **kw)
    for i, s in enumerate(result.steps, 1):
        bad = s.score is not None and s.score < 0.95
        score = "?" if s.score is None else f"{s.score:.3f}"
        table.add_row(str(i), ",".join(s.moving), ",".join(s.fixed),
                      f"({s.direction[0] + 0.0:+.3f},{s.direction[1] + 0.0:+.3f})",
                      f"[red]{score}[/]" if bad else score, s.source,
                      "" if s.confidence is None else f"{s.confidence:.3f}")
    console.print(table)
    st = result.stats
    line = f"robustness R = {result.robustness:.4f} (product of the simulator's step scores)"
    if result.method == "random" and "mean_robustness" in st:
        line += (f"; mean over {st['samples']} random sequences = {st['mean_robustness']:.4f} "
                 f"(shown: the sample closest to the mean)")
    console.print(line)
    parts = [f"planning {result.seconds:.2f} s", f"evaluation {result.eval_seconds:.2f} s"]
    if wall_s is not None:
        parts.append(f"wall {wall_s:.2f} s" + (" (Ray start-up included)" if ray else ""))
    if st.get("service_seconds") is not None and not ray:
        parts.append(f"service {st['service_seconds']:.2f} s")
    console.print("time: " + ", ".join(parts))
    facts = [f"{st.get('sim_run', 0)} simulations run", f"{st.get('cache_hits', 0)} cached scores used"]
    if st.get("cnn_batches"):
        facts.append(f"{st['cnn_ops']} CNN scores in {st['cnn_batches']} batches")
    if result.method == "rap":
        facts.append(f"simulator fallbacks: {st.get('fallbacks', 0)} of {st.get('decisions', 0)} "
                     f"decisions")
    if result.method == "search":
        how = (f"exact DP over {st.get('operations', '?')} operations" if st.get("search") == "exact"
               else f"beam of width {st.get('beam_width')}")
        facts.append(f"search: {how}, {st.get('predicted_operations', 0)} operations scored by "
                     f"the model, {st.get('search_simulations', 0)} simulated while planning")
    if result.method == "optimal" and "subassemblies" in st:
        facts.append(f"DP over {st['subassemblies']} subassemblies / {st['operations']} operations "
                     f"vs. {st['exhaustive_sequences']:,} sequences for an exhaustive search "
                     f"({st['dp_speedup']:.0f}x fewer step evaluations)")
    console.print("; ".join(facts))
