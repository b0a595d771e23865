"""``rap-farm score MODEL DATASET``: an existing checkpoint's accuracy on a dataset, no training."""

from __future__ import annotations

import json
from pathlib import Path

import typer

__all__ = ["register", "score_command"]


def score_command(
    model: Path = typer.Argument(..., help="Checkpoint (.pt) written by `rap-farm train`."),
    dataset: Path = typer.Argument(..., help="Dataset directory written by `rap-farm label`."),
    by: str = typer.Option("assembly", "--by", help="Rows per assembly or per family."),
    out: Path = typer.Option(None, "--out", "-o", help="Also write score.json and score.md here."),
    device: str = typer.Option("cpu", "--device", help="cpu, cuda or auto."),
    only: list[str] = typer.Option(None, "--only",
                                   help="Only the rows of this assembly (family with --by family); "
                                        "repeatable."),
    mirror: bool = typer.Option(False, "--mirror",
                                help="Average the network's outputs over each image pair and its "
                                     "mirror image (twice the inference)."),
):
    """Accuracy, per-class accuracy, ECE and the noise ceiling of MODEL on DATASET, per assembly
    (or family) and overall."""
    from rap.commands._console import console as make_console
    from rap.commands._flags import flags
    from rap.errors import InputError
    from rap.model.evaluation.cross_validation import score_checkpoint

    if by not in ("assembly", "family"):
        raise InputError(f"--by {by!r}: assembly or family")
    from rap.commands.check import warn_duplicates

    warn_duplicates(dataset)  # each key is scored once
    with flags("device"):
        rows = score_checkpoint(model, dataset, by=by, device=device, only=only or None,
                                mirror=mirror)
    if not rows:
        raise InputError(f"{dataset}: no rows" + (f" of {', '.join(only)}" if only else ""))
    from rich.table import Table

    pct = lambda x: "–" if x != x else f"{100 * x:.1f}"  # noqa: E731 (NaN: empty class)
    table = Table(title=f"{model.name} on {Path(dataset).resolve().name}"
                        + (", mirror-averaged" if mirror else ""))
    for col in (by, "rows", "high", "accuracy %", "low %", "high %", "ECE %", "ceiling %"):
        table.add_column(col, justify="left" if col == by else "right")
    lines = [f"| {by} | rows | high | accuracy | low robustness | high robustness | ECE | ceiling |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        cells = [str(r[by]), str(r["rows"]), str(r["high_rows"]), pct(r["accuracy"]),
                 pct(r["low_accuracy"]), pct(r["high_accuracy"]), pct(r["ece"]), pct(r["ceiling"])]
        table.add_row(*cells, style="bold" if r[by] == "all" else None)
        lines.append("| " + " | ".join(cells) + " |")
    make_console().print(table)
    if out:
        out.mkdir(parents=True, exist_ok=True)
        safe = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
                for r in rows]
        (out / "score.json").write_text(json.dumps({"model": str(model), "dataset": str(dataset),
                                                    "by": by, "mirror": mirror, "rows": safe},
                                                   indent=2))
        (out / "score.md").write_text("\n".join(lines) + "\n")
        typer.echo(f"wrote {out / 'score.json'}, {out / 'score.md'}")


def register(app: typer.Typer) -> None:
    app.command("score")(score_command)
