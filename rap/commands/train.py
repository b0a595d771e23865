"""``rap-farm train``: train the robustness CNN on a labelled dataset and save a checkpoint."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from rap.commands._model_options import (AUGMENT_OPTION, CALIBRATE_OPTION, CHANNELS_OPTION,
                                         DESCRIPTORS_OPTION, HEAD_OPTION, HIDDEN_OPTION, LR_OPTION,
                                         MAX_ROWS_OPTION, NORM_OPTION, RECIPE_OPTION,
                                         SCHEDULE_OPTION, VAL_BY_OPTION, VIEW_OPTION, describe,
                                         resolve)

__all__ = ["register", "train_command"]


def progress_bar(console=None):
    """A rich progress bar and an ``on_step`` callback that advances it (loss, accuracy shown).
    On a console that is not a terminal (a log file, a Ray Job's log) a bar would show only at
    the end: no bar then, one line per completed epoch instead (``epoch_lines``)."""
    if console is not None and not console.is_terminal:
        import contextlib

        return contextlib.nullcontext(), epoch_lines(console)
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                               TimeElapsedColumn, TimeRemainingColumn)

    bar = Progress(TextColumn("{task.description} {task.fields[epoch]}"), BarColumn(),
                   MofNCompleteColumn(), TextColumn("{task.fields[stats]}"),
                   TimeElapsedColumn(), TimeRemainingColumn(), console=console, transient=False)
    state = {}

    def on_step(ev: dict) -> None:  # a new bar per ev["task"] (evaluate's folds, rendering)
        total = ev["steps"] * ev["epochs"]
        name = ev.get("task", "train")
        if state.get("name") != name:
            state["name"] = name
            state["task"] = bar.add_task(name, total=total, epoch="", stats="")
        stats = (f"loss {ev['loss']:.4f}  acc {ev['accuracy']:.3f}" if "loss" in ev else "")
        bar.update(state["task"], completed=(ev["epoch"] - 1) * ev["steps"] + ev["step"],
                   epoch=f"epoch {ev['epoch']}/{ev['epochs']}" if stats else "", stats=stats)

    return bar, on_step


def _mtime(path: Path) -> int | None:
    try:
        return path.stat().st_mtime_ns
    except FileNotFoundError:
        return None


def epoch_lines(console):
    """An ``on_step`` callback that prints a line when an epoch (or a view's rendering) ends:
    ``train epoch 2/6: loss 0.2914, accuracy 0.761 (1,327 s)``."""
    import time

    t0 = time.perf_counter()

    def on_step(ev: dict) -> None:
        if ev["step"] != ev["steps"]:
            return
        name, elapsed = ev.get("task", "train"), time.perf_counter() - t0
        if "loss" in ev:
            console.print(f"{name} epoch {ev['epoch']}/{ev['epochs']}: loss {ev['loss']:.4f}, "
                          f"accuracy {ev['accuracy']:.3f} ({elapsed:,.0f} s)", highlight=False)
        else:
            console.print(f"{name}: {ev['steps']:,} rows ({elapsed:,.0f} s)", highlight=False)

    return on_step


def train_command(
    dataset: Path = typer.Argument(..., help="Dataset directory written by `rap-farm label`."),
    out: Path = typer.Option(None, "--out", "-o",
                             help="Checkpoint to write [default: models/<dataset name>.pt]."),
    holdout: str = typer.Option(None, "--holdout",
                                help="Leave this assembly out of training and report metrics on it."),
    holdout_family: str = typer.Option(None, "--holdout-family",
                                       help="Leave this family out of training and report metrics on it."),
    epochs: int = typer.Option(8, "--epochs", min=1, help="Passes over the training rows."),
    device: str = typer.Option("auto", "--device", help="auto (CUDA when present), cpu or cuda."),
    seed: int = typer.Option(0, "--seed", help="Seed of initialisation, dropout and shuffling."),
    batch_size: int = typer.Option(64, "--batch-size", min=1),
    threshold: float = typer.Option(0.95, "--threshold",
                                    help="A score >= threshold is the class 'high'."),
    threads: int = typer.Option(0, "--threads", min=0,
                                help="torch CPU threads (0: torch's default)."),
    recipe: str = RECIPE_OPTION,
    head: Optional[str] = HEAD_OPTION,
    norm: Optional[str] = NORM_OPTION,
    augment: Optional[str] = AUGMENT_OPTION,
    calibrate: Optional[bool] = CALIBRATE_OPTION,
    lr: Optional[float] = LR_OPTION,
    schedule: Optional[str] = SCHEDULE_OPTION,
    max_rows: Optional[int] = MAX_ROWS_OPTION,
    view: Optional[str] = VIEW_OPTION,
    descriptors: Optional[str] = DESCRIPTORS_OPTION,
    channels: Optional[str] = CHANNELS_OPTION,
    hidden: Optional[str] = HIDDEN_OPTION,
    val_by: Optional[str] = VAL_BY_OPTION,
    init: Optional[Path] = typer.Option(
        None, "--init",
        help="Start from this checkpoint's weights (same recipe and network): fine-tune a model, "
             "e.g. rap/data/default_model.pt on your own labelled assemblies, or train it longer."),
    resume: bool = typer.Option(
        True, "--resume/--restart",
        help="After every epoch the run's state is saved beside the checkpoint (OUT.resume); "
             "the same command after an interruption continues from the last epoch. --restart "
             "starts over."),
):
    """Train the robustness CNN with a recipe (default 'robust') and save a checkpoint."""
    from rap.commands._console import console as make_console
    from rap.commands._flags import flags

    from rap.model.training.train import train

    out = out or Path("models") / f"{Path(dataset).resolve().name}.pt"
    model_config, config = resolve(recipe, epochs=epochs, batch_size=batch_size, seed=seed,
                                   device=device, threshold=threshold, num_threads=threads,
                                   head=head, norm=norm, augment=augment, calibrate=calibrate,
                                   lr=lr, schedule=schedule, max_rows=max_rows, view=view,
                                   channels=channels, hidden=hidden, val_by=val_by,
                                   descriptors=descriptors)
    from rap.commands.check import warn_duplicates

    warn_duplicates(dataset)  # each key is one training row
    state = resume_path(out)
    if not resume:
        state.unlink(missing_ok=True)
    state_before = _mtime(state)
    console = make_console(stderr=True)
    bar, on_step = progress_bar(console)
    import shlex
    import sys

    try:
        with flags("holdout", "holdout_family", "init", "max_rows", "device"), bar:
            result = train(dataset, holdout=holdout, holdout_family=holdout_family,
                           model_config=model_config, config=config, on_step=on_step,
                           command=" ".join(shlex.quote(a) for a in ["rap-farm", *sys.argv[1:]]),
                           init=init, resume=state)
    except KeyboardInterrupt:
        from rap.errors import EXIT_INTERRUPTED

        now = _mtime(state)
        if now is not None and now != state_before:
            kept = f"the epochs completed are kept in {state}; the same command resumes"
        elif now is not None:  # left by an earlier run: resumed from, or to be replaced
            kept = f"no epoch was completed in this run; {state} is as it was"
        else:
            kept = "no epoch was completed"
        print(f"rap-farm: interrupted; {kept}", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    path = result.save(out)
    state.unlink(missing_ok=True)
    r = result.training.get("resume") or {}
    if r.get("from_epoch"):
        typer.echo(f"resumed from epoch {r['from_epoch']} of {config.epochs} ({state})")
    elif r.get("replaced"):
        typer.echo(f"{state} was left by another training (other options or rows): replaced")
    tr = result.metrics["train"]
    t = result.training
    typer.echo(f"robustness CNN ({recipe}): {describe(model_config, config)}"
               + (f", starting from {init}" if init is not None else ""))
    typer.echo(f"trained on {tr['rows']} rows ({tr['high_rows']} high) on {t['device']}: "
               f"{tr['samples_per_s']:.0f} samples/s, {t['seconds']:.1f} s")
    if result.calibration:
        c = result.calibration
        typer.echo(f"calibration temperature {c['temperature']:.3f} (fitted on {c['rows']} rows "
                   f"of {len(c['assemblies'])} held-out assemblies)")
    if "holdout" in result.metrics:
        h = result.metrics["holdout"]
        pct = lambda x: "–" if x != x else f"{100 * x:.1f}%"  # noqa: E731 (NaN: empty class)
        typer.echo(f"holdout {h['assembly']}: accuracy {pct(h['accuracy'])}, low robustness "
                   f"{pct(h['low_accuracy'])}, high robustness {pct(h['high_accuracy'])}, "
                   f"ECE {pct(h['ece'])}, noise ceiling {pct(h.get('ceiling', float('nan')))} "
                   f"({h['rows']} rows, {h['high_rows']} high)")
    typer.echo(f"wrote {path}")


def resume_path(out: Path) -> Path:
    """Where ``rap-farm train -o OUT`` keeps its epoch state: ``OUT.resume``."""
    out = Path(out)
    return out.with_name(out.name + ".resume")


def register(app: typer.Typer) -> None:
    app.command("train")(train_command)
