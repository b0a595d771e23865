"""Leave-one-assembly-out cross-validation of the robustness CNN (the paper's Table I).

For each assembly of a dataset, a model is trained on the others and tested on it. A fold is one
call of ``run_fold`` over plain values, so folds run in-process one after the other
(``sequential_folds``) or as parallel tasks elsewhere (``rap.farm.folds``, which wraps the same
function for Ray). ``write_report`` writes the table (Markdown, CSV), the per-fold metrics (JSON)
and a plot: accuracies per test assembly and the pooled reliability diagram of P(high).
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from rap.model.cnn import ModelConfig
from rap.model.metrics import expected_calibration_error, pool_reliability, reliability_table
from rap.model.train import TrainConfig, dataset_assemblies, train

__all__ = ["fold_specs", "run_fold", "sequential_folds", "cross_validate", "summary_rows",
           "write_report", "COLUMNS"]

COLUMNS = ("accuracy", "low_accuracy", "high_accuracy")
FoldRunner = Callable[[list[dict]], Iterable[dict]]


def fold_specs(root: str | Path, model_config: ModelConfig, config: TrainConfig,
               assemblies: list[str] | None = None, models_dir: str | Path | None = None) -> list[dict]:
    """One plain-dict spec per test assembly (all of the dataset's by default)."""
    root = str(Path(root).resolve())
    names = assemblies or dataset_assemblies(root)
    specs = []
    for name in names:
        save_to = str(Path(models_dir).resolve() / f"holdout-{name}.pt") if models_dir else None
        specs.append({"root": root, "assembly": name, "model_config": model_config.to_dict(),
                      "train_config": config.to_dict(), "save_to": save_to})
    return specs


def run_fold(spec: dict) -> dict:
    """Train without ``spec["assembly"]``, test on it; save the model when ``save_to`` is set.
    Returns plain values: assembly, holdout metrics, training summary, seconds, checkpoint path."""
    t0 = time.perf_counter()
    result = train(spec["root"], holdout=spec["assembly"],
                   model_config=ModelConfig.from_dict(spec["model_config"]),
                   config=TrainConfig(**spec["train_config"]))
    if spec.get("save_to"):
        result.save(spec["save_to"])
    return {"assembly": spec["assembly"], "metrics": result.metrics["holdout"],
            "train": result.metrics["train"], "seconds": time.perf_counter() - t0,
            "checkpoint": spec.get("save_to")}


def sequential_folds(specs: list[dict]) -> Iterator[dict]:
    for spec in specs:
        yield run_fold(spec)


def cross_validate(specs: list[dict], runner: FoldRunner = sequential_folds,
                   on_fold: Callable[[dict], None] | None = None) -> list[dict]:
    """Run every fold with ``runner`` (in whatever order it finishes them); sorted by assembly."""
    folds = []
    for fold in runner(specs):
        folds.append(fold)
        if on_fold is not None:
            on_fold(fold)
    return sorted(folds, key=lambda f: f["assembly"])


def summary_rows(folds: list[dict]) -> list[dict]:
    """One row per fold plus the mean over folds (unweighted, as in the paper)."""
    rows = []
    for f in folds:
        m = f["metrics"]
        rows.append({"assembly": f["assembly"], "rows": m["rows"], "high_rows": m["high_rows"],
                     **{c: m[c] for c in COLUMNS}, "ece": m["ece"],
                     "train_rows": f["train"]["rows"], "seconds": f["seconds"]})
    mean = {"assembly": "mean", "rows": sum(r["rows"] for r in rows),
            "high_rows": sum(r["high_rows"] for r in rows),
            "train_rows": "", "seconds": sum(r["seconds"] for r in rows)}
    for c in (*COLUMNS, "ece"):
        vals = [r[c] for r in rows if not math.isnan(r[c])]
        mean[c] = float(np.mean(vals)) if vals else math.nan
    return rows + [mean]


def _pct(x) -> str:
    return "–" if isinstance(x, float) and math.isnan(x) else f"{100 * x:.2f}"


def _markdown(folds: list[dict], rows: list[dict], pooled: dict, title: str, notes: dict) -> str:
    out = [f"# {title}", "",
           "Leave-one-assembly-out cross-validation: each row is a model trained on every other "
           "assembly and tested on this one. Low / high robustness: accuracy on the rows whose "
           f"score is below / at least the threshold {notes['threshold']}. Percent.", "",
           "| Test assembly | Rows | High rows | Accuracy | Low robustness | High robustness | ECE |",
           "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        name = f"**{r['assembly']}**" if r["assembly"] == "mean" else r["assembly"]
        out.append(f"| {name} | {r['rows']} | {r['high_rows']} | {_pct(r['accuracy'])} | "
                   f"{_pct(r['low_accuracy'])} | {_pct(r['high_accuracy'])} | {_pct(r['ece'])} |")
    out += ["", "## Calibration of P(high) (all folds pooled)", "",
            f"Expected calibration error: {_pct(expected_calibration_error(pooled))}% "
            "(row-weighted mean |mean P(high) - observed fraction high| over 10 bins).", "",
            "| P(high) bin | Rows | Mean P(high) | Observed high |", "|---|---:|---:|---:|"]
    for b in reliability_table(pooled):
        out.append(f"| {b['lo']:.1f}-{b['hi']:.1f} | {b['rows']} | {_pct(b['mean_prob_high'])} | "
                   f"{_pct(b['frac_high'])} |")
    out += ["", "## Setup", ""]
    out += [f"- {k}: {v}" for k, v in notes.items()]
    return "\n".join(out) + "\n"


def _plot(rows: list[dict], pooled: dict, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [2, 1]})
    x = np.arange(len(rows))
    for i, (c, label) in enumerate(zip(COLUMNS, ("accuracy", "low robustness", "high robustness"))):
        ax.bar(x + (i - 1) * 0.27, [100 * np.nan_to_num(r[c]) for r in rows], 0.27, label=label)
    ax.set_xticks(x, [r["assembly"] for r in rows], rotation=20)
    ax.set_ylabel("accuracy (%)")
    ax.set_ylim(0, 100)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title)
    table = [b for b in reliability_table(pooled) if b["rows"]]
    ax2.plot([0, 1], [0, 1], ls="--", c="grey", lw=1)
    ax2.plot([b["mean_prob_high"] for b in table], [b["frac_high"] for b in table], "o-")
    ax2.set_xlabel("predicted P(high)")
    ax2.set_ylabel("observed fraction high")
    ax2.set_title(f"reliability (ECE {100 * expected_calibration_error(pooled):.1f}%)")
    ax2.set_xlim(0, 1)
    ax2.set_ylim(0, 1)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _json_safe(value):
    """NaN (an empty class) as null, so folds.json is strict JSON."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json_safe(v) for v in value]
    return value


def write_report(folds: list[dict], out_dir: str | Path, title: str, notes: dict) -> list[Path]:
    """table.md, table.csv, folds.json and crossval.png under ``out_dir``. Returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = summary_rows(folds)
    pooled = pool_reliability([f["metrics"]["reliability"] for f in folds])
    paths = [out / "table.md", out / "table.csv", out / "folds.json", out / "crossval.png"]
    paths[0].write_text(_markdown(folds, rows, pooled, title, notes))
    with open(paths[1], "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    report = {"notes": notes, "folds": folds, "pooled_reliability": reliability_table(pooled)}
    paths[2].write_text(json.dumps(_json_safe(report), indent=2, allow_nan=False))
    _plot(rows, pooled, paths[3], title)
    return paths
