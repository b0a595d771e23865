"""Cross-validation of the robustness CNN: leave one assembly out (the paper's Table I) and leave
one family out (generalisation to a kind of assembly never seen).

A fold is a test set, one assembly (``kind="assembly"``) or every assembly of one family
(``kind="family"``), and a model trained on all the other rows of the dataset. A fold is one call
of ``run_fold`` over plain values, so folds run in-process one after the other
(``sequential_folds``, sharing one in-memory ``RowStore`` of the dataset) or as parallel tasks
elsewhere (``rap.farm.folds``, which wraps the same function for Ray). Every fold reports accuracy,
per-class accuracy, ECE and the noise ceiling of its test rows (``rap.model.evaluation.metrics``).

``write_report`` writes one table per kind (Markdown, CSV), the per-fold metrics (JSON) and a plot
per kind: accuracies per test set and the pooled reliability diagram of P(high).
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np

from rap.dataset import IMAGE_BYTES
from rap.model.network.cnn import ModelConfig
from rap.model.data.rows import RowStore, select
from rap.model.evaluation.metrics import expected_calibration_error, pool_reliability, reliability_table
from rap.model.training.train import TrainConfig, train
from rap.model.training.trainset import dataset_assemblies

__all__ = ["fold_specs", "run_fold", "sequential_folds", "cross_validate", "summary_rows",
           "write_report", "COLUMNS", "KINDS", "row_store"]

COLUMNS = ("accuracy", "low_accuracy", "high_accuracy")
KINDS = ("assembly", "family")
_STORES: dict[str, RowStore] = {}


def row_store(root: str | Path, max_memory_mb: float) -> RowStore | None:
    """The dataset held in memory once per process (None when it does not fit the budget)."""
    root = str(Path(root).resolve())
    if root not in _STORES:
        if select(root).count() * (IMAGE_BYTES + 256) > max_memory_mb * 2 ** 20:
            return None
        _STORES.clear()
        _STORES[root] = RowStore(root)
    return _STORES[root]
FoldRunner = Callable[[list[dict]], Iterable[dict]]


def fold_specs(root: str | Path, model_config: ModelConfig, config: TrainConfig,
               assemblies: list[str] | None = None, models_dir: str | Path | None = None,
               kind: str = "assembly") -> list[dict]:
    """One plain-dict spec per test set: per assembly (all of the dataset's by default) or, with
    ``kind="family"``, per family (``assemblies`` then names families). The fold's model is saved
    as ``holdout-NAME.pt`` (``holdout-family-NAME.pt``) under ``models_dir`` when given."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}")
    root = str(Path(root).resolve())
    names = assemblies or dataset_assemblies(root)
    specs = []
    for name in names:
        stem = f"holdout-{name}" if kind == "assembly" else f"holdout-family-{name}"
        save_to = str(Path(models_dir).resolve() / f"{stem}.pt") if models_dir else None
        specs.append({"root": root, "kind": kind, "assembly": name,
                      "model_config": model_config.to_dict(), "train_config": config.to_dict(),
                      "save_to": save_to})
    return specs


def run_fold(spec: dict, on_step: Callable[[dict], None] | None = None) -> dict:
    """Train without the fold's test set, test on it; save the model when ``save_to`` is set.
    Returns plain values: kind, test name (``assembly``), holdout metrics, training summary,
    seconds, checkpoint path. ``on_step`` gets ``rap.model.training.train.train``'s events with
    ``"task": "KIND NAME"`` added (an event that names its own task, rendering, keeps it)."""
    t0 = time.perf_counter()
    config = TrainConfig(**spec["train_config"])
    kind = spec.get("kind", "assembly")
    store = row_store(spec["root"], config.max_memory_mb)
    task = f"{kind} {spec['assembly']}"
    result = train(spec["root"], holdout=spec["assembly"] if kind == "assembly" else None,
                   holdout_family=spec["assembly"] if kind == "family" else None,
                   model_config=ModelConfig.from_dict(spec["model_config"]), config=config,
                   store=store,
                   on_step=None if on_step is None else (lambda ev: on_step({"task": task, **ev})))
    if spec.get("save_to"):
        result.save(spec["save_to"])
    return {"kind": kind, "assembly": spec["assembly"], "metrics": result.metrics["holdout"],
            "train": result.metrics["train"], "calibration": result.calibration,
            "seconds": time.perf_counter() - t0, "checkpoint": spec.get("save_to")}


def sequential_folds(specs: list[dict],
                     on_step: Callable[[dict], None] | None = None) -> Iterator[dict]:
    """The folds one after the other in this process (``on_step``: see ``run_fold``)."""
    for spec in specs:
        yield run_fold(spec, on_step)


def cross_validate(specs: list[dict], runner: FoldRunner = sequential_folds,
                   on_fold: Callable[[dict], None] | None = None) -> list[dict]:
    """Run every fold with ``runner`` (in whatever order it finishes them); sorted by assembly."""
    folds = []
    for fold in runner(specs):
        folds.append(fold)
        if on_fold is not None:
            on_fold(fold)
    return sorted(folds, key=lambda f: (KINDS.index(f.get("kind", "assembly")), f["assembly"]))


def summary_rows(folds: list[dict]) -> list[dict]:
    """One row per fold plus the mean over folds (unweighted, as in the paper). Folds of one kind."""
    rows = []
    for f in folds:
        m = f["metrics"]
        rows.append({"assembly": f["assembly"], "rows": m["rows"], "high_rows": m["high_rows"],
                     **{c: m[c] for c in COLUMNS}, "ece": m["ece"],
                     "ceiling": m.get("ceiling", math.nan),
                     "train_rows": f["train"]["rows"], "seconds": f["seconds"]})
    mean = {"assembly": "mean", "rows": sum(r["rows"] for r in rows),
            "high_rows": sum(r["high_rows"] for r in rows),
            "train_rows": "", "seconds": sum(r["seconds"] for r in rows)}
    for c in (*COLUMNS, "ece", "ceiling"):
        vals = [r[c] for r in rows if not math.isnan(r[c])]
        mean[c] = float(np.mean(vals)) if vals else math.nan
    return rows + [mean]


def _pct(x) -> str:
    return "–" if isinstance(x, float) and math.isnan(x) else f"{100 * x:.2f}"


_HEADINGS = {
    "assembly": ("Leave one assembly out", "Test assembly",
                 "each row is a model trained on every other assembly of the dataset and tested "
                 "on this one"),
    "family": ("Leave one family out", "Test family",
               "each row is a model trained on every assembly outside this family and tested on "
               "all of the family's assemblies"),
}


def _markdown(by_kind: dict, title: str, notes: dict) -> str:
    out = [f"# {title}", ""]
    for kind, (folds, rows, pooled) in by_kind.items():
        heading, col, what = _HEADINGS[kind]
        out += [f"## {heading}", "",
                f"{heading}: {what}. Low / high robustness: accuracy on the rows whose score is "
                f"below / at least the threshold {notes['threshold']}. Ceiling: the expected "
                "agreement of a perfect model with these noisy labels (see rap.model.evaluation.metrics). "
                "Percent.", "",
                f"| {col} | Rows | High rows | Accuracy | Low robustness | High robustness | ECE | "
                "Ceiling |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for r in rows:
            name = f"**{r['assembly']}**" if r["assembly"] == "mean" else r["assembly"]
            out.append(f"| {name} | {r['rows']} | {r['high_rows']} | {_pct(r['accuracy'])} | "
                       f"{_pct(r['low_accuracy'])} | {_pct(r['high_accuracy'])} | "
                       f"{_pct(r['ece'])} | {_pct(r['ceiling'])} |")
        out += ["", f"### Calibration of P(high) ({heading.lower()}, all folds pooled)", "",
                f"Expected calibration error: {_pct(expected_calibration_error(pooled))}% "
                "(row-weighted mean |mean P(high) - observed fraction high| over 10 bins).", "",
                "| P(high) bin | Rows | Mean P(high) | Observed high |", "|---|---:|---:|---:|"]
        for b in reliability_table(pooled):
            out.append(f"| {b['lo']:.1f}-{b['hi']:.1f} | {b['rows']} | "
                       f"{_pct(b['mean_prob_high'])} | {_pct(b['frac_high'])} |")
        out.append("")
    out += ["## Setup", ""]
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
    """table.md, table.csv, folds.json and crossval.png (crossval-family.png for family folds)
    under ``out_dir``. Returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    by_kind = {}
    for kind in KINDS:
        fk = [f for f in folds if f.get("kind", "assembly") == kind]
        if fk:
            by_kind[kind] = (fk, summary_rows(fk),
                             pool_reliability([f["metrics"]["reliability"] for f in fk]))
    paths = [out / "table.md", out / "table.csv", out / "folds.json"]
    paths[0].write_text(_markdown(by_kind, title, notes))
    with open(paths[1], "w", newline="") as fh:
        w = None
        for kind, (_, rows, _) in by_kind.items():
            for r in rows:
                r = {"kind": kind, **r}
                if w is None:
                    w = csv.DictWriter(fh, fieldnames=list(r))
                    w.writeheader()
                w.writerow(r)
    report = {"notes": notes, "folds": folds,
              "pooled_reliability": {k: reliability_table(v[2]) for k, v in by_kind.items()}}
    paths[2].write_text(json.dumps(_json_safe(report), indent=2, allow_nan=False))
    for kind, (_, rows, pooled) in by_kind.items():
        png = out / ("crossval.png" if kind == "assembly" or len(by_kind) == 1
                     else f"crossval-{kind}.png")
        _plot(rows, pooled, png, f"{title} ({_HEADINGS[kind][0].lower()})")
        paths.append(png)
    return paths


def score_checkpoint(model_path: str | Path, root: str | Path, *, by: str = "assembly",
                     device: str = "cpu", batch_size: int = 512,
                     only: Sequence[str] | None = None, mirror: bool = False) -> list[dict]:
    """Metrics of an existing checkpoint on a dataset, without training: one row per assembly
    (``by="assembly"``) or per family (``by="family"``) plus an ``all`` row; ``only`` keeps the
    rows of those assemblies (families); ``mirror`` averages the outputs over each pair and its
    mirror image (``rap.model.inference.torch_engine.TorchPredictor``). A key stored more than once counts once (its
    first row: ``rap.dataset.duplicate_keys``). Streams the dataset (O(batch) memory besides the
    per-row labels and probabilities)."""
    from rap.dataset import decode_images, iter_batches
    from rap.model.inference.torch_engine import TorchPredictor

    if by not in KINDS:
        raise ValueError(f"by must be one of {KINDS}")
    pred = TorchPredictor.load(model_path, device=device, mirror=mirror)
    if pred.view != "pair":
        from rap.errors import InputError

        raise InputError(f"{model_path}: takes the {pred.view} view, rendered again from geometry; "
                         f"score it with python -m research.score_models")
    groups, scores, trials, probs = [], [], [], []
    import pyarrow.compute as pc

    keep = None if not only else pc.field(by).isin(list(only))
    columns = ["assembly", "family", "score", "trials", "image"]
    geometry, operation_columns = None, ["geometry_hash", "moving", "fixed", "direction_x",
                                         "direction_y"]
    if pred.descriptors:  # computed from the dataset's geometry, batch by batch
        from rap.model.data.views import DatasetGeometry

        geometry = DatasetGeometry(root)
        columns += operation_columns
    for rb in iter_batches(root, columns=columns, batch_size=batch_size, filter=keep, unique=True):
        if not rb.num_rows:
            continue
        g = rb.column(by).to_pylist()
        groups += [x if x is not None else "custom" for x in g]
        scores.append(rb.column("score").to_numpy())
        trials.append(rb.column("trials").to_numpy())
        d = None
        if geometry is not None:
            col = {c: rb.column(c).to_pylist() for c in operation_columns}
            d = geometry.descriptors(pred.descriptors, rb.column("assembly").to_pylist(),
                                     col["geometry_hash"], col["moving"], col["fixed"],
                                     list(zip(col["direction_x"], col["direction_y"])))
        probs.append(pred.prob_high(decode_images(rb.column("image")), d))
    if not groups:
        return []
    return group_metrics(np.array(groups, dtype=object), np.concatenate(scores),
                         np.concatenate(trials), np.concatenate(probs), pred.threshold, by)


def group_metrics(groups: np.ndarray, scores: np.ndarray, trials: np.ndarray,
                  prob_high: np.ndarray, threshold: float, by: str = "assembly") -> list[dict]:
    """``classification_metrics`` per group (sorted) and over all rows (``{by: "all"}``, last)."""
    from rap.model.evaluation.metrics import classification_metrics
    from rap.model.evaluation.heldout import successes_of

    rows = []
    for name in [*sorted(set(groups.tolist())), None]:
        m = np.ones(len(scores), dtype=bool) if name is None else groups == name
        met = classification_metrics((scores[m] >= threshold).astype(np.int64), prob_high[m],
                                     successes_of(scores[m], trials[m]), trials[m], threshold,
                                     reliability=False)
        rows.append({by: "all" if name is None else name, **met})
    return rows
