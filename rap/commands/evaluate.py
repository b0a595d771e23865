"""``rap-farm evaluate``: cross-validation of the robustness CNN by assembly and by family.

``--by auto`` (the default): leave each *reference* assembly out (the paper's Table I) when the
dataset has the six reference assemblies, else each assembly; and leave each generated family out
when the dataset has two or more families besides ``reference``/``custom``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

import typer

from rap.commands._model_options import (AUGMENT_OPTION, CALIBRATE_OPTION, CHANNELS_OPTION,
                                         DESCRIPTORS_OPTION, HEAD_OPTION, HIDDEN_OPTION, LR_OPTION,
                                         MAX_ROWS_OPTION, NORM_OPTION, RECIPE_OPTION,
                                         SCHEDULE_OPTION, VAL_BY_OPTION, VIEW_OPTION, describe,
                                         resolve)

_NOT_GENERATED = ("reference", "custom")


def plan_folds(dataset, by: str, assemblies: str | None, families: str | None):
    """[(kind, [test names])] for the dataset and options (see the module docstring)."""
    from rap.errors import InputError
    from rap.model.training.trainset import dataset_families

    fams = dataset_families(dataset)
    all_names = sorted({a for v in fams.values() for a in v})
    generated = [f for f in fams if f not in _NOT_GENERATED]
    if by not in ("auto", "assembly", "family", "both"):
        raise InputError(f"--by {by!r}: auto, assembly, family or both")
    out = []
    if by in ("auto", "assembly", "both"):
        if assemblies:
            names = [a.strip() for a in assemblies.split(",") if a.strip()]
            missing = sorted(set(names) - set(all_names))
            if missing:
                raise InputError(f"--assemblies: not in {dataset}: {', '.join(missing)}")
        elif by == "auto" and "reference" in fams:
            names = fams["reference"]
        else:
            names = all_names
        if len(all_names) < 2:
            raise InputError(f"{dataset}: leave-one-assembly-out needs at least two assemblies "
                             f"(has: {', '.join(all_names)})")
        out.append(("assembly", names))
    if by in ("family", "both") or (by == "auto" and len(generated) >= 2):
        names = ([f.strip() for f in families.split(",") if f.strip()] if families
                 else generated)
        missing = sorted(set(names) - set(fams))
        if missing:
            raise InputError(f"--families: not in {dataset}: {', '.join(missing)}")
        if len(fams) < 2:
            raise InputError(f"{dataset}: leave-one-family-out needs at least two families")
        out.append(("family", names))
    return out

__all__ = ["register", "evaluate_command"]


def _runner(no_ray: bool, device: str, console):
    """Ray tasks when allowed, available and useful (several cores or a cluster address, CPU
    training); otherwise the folds run one after the other in this process."""
    from rap.commands._flags import flags
    from rap.model.evaluation.cross_validation import sequential_folds
    from rap.model.inference.torch_engine import resolve_device

    if no_ray:
        return sequential_folds, "in-process (--no-ray)"
    with flags("device"):
        on_cpu = resolve_device(device).type == "cpu"
    if not on_cpu:
        return sequential_folds, "in-process on the GPU"
    if (os.cpu_count() or 1) < 2 and not os.environ.get("RAY_ADDRESS"):
        return sequential_folds, "in-process (one core)"
    try:
        from rap.farm.folds import ray_folds
    except ImportError as exc:
        console.print(f"ray unavailable ({exc}); running the folds in-process")
        return sequential_folds, "in-process (ray unavailable)"
    return ray_folds, "parallel Ray tasks, one torch thread each"


def evaluate_command(
    dataset: Path = typer.Argument(..., help="Dataset directory written by `rap-farm label`."),
    out: Path = typer.Option(None, "--out", "-o",
                             help="Report directory [default: reports/<dataset name>]."),
    epochs: int = typer.Option(8, "--epochs", min=1, help="Training epochs per fold."),
    device: str = typer.Option("auto", "--device", help="auto (CUDA when present), cpu or cuda."),
    seed: int = typer.Option(0, "--seed"),
    batch_size: int = typer.Option(64, "--batch-size", min=1),
    threshold: float = typer.Option(0.95, "--threshold",
                                    help="A score >= threshold is the class 'high'."),
    no_ray: bool = typer.Option(False, "--no-ray", help="Run the folds sequentially in-process."),
    save_models: bool = typer.Option(True, "--save-models/--no-save-models",
                                     help="Keep each fold's model as OUT/models/holdout-NAME.pt."),
    by: str = typer.Option("auto", "--by",
                           help="auto, assembly, family or both (see `rap-farm evaluate --help`)."),
    assemblies: Optional[str] = typer.Option(None, "--assemblies",
                                             help="Comma-separated test assemblies."),
    families: Optional[str] = typer.Option(None, "--families",
                                           help="Comma-separated test families."),
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
):
    """Train one model per held-out assembly / family; write accuracy tables (with the noise
    ceiling), calibration and plots."""
    import time

    from rap.commands._console import console as make_console

    from rap.model.evaluation.cross_validation import cross_validate, fold_specs, summary_rows, write_report

    console = make_console(stderr=True)
    name = Path(dataset).resolve().name
    out = out or Path("reports") / name
    model_config, config = resolve(recipe, epochs=epochs, batch_size=batch_size, seed=seed,
                                   device=device, threshold=threshold, head=head, norm=norm,
                                   augment=augment, calibrate=calibrate, lr=lr,
                                   schedule=schedule, max_rows=max_rows, view=view,
                                   channels=channels, hidden=hidden, val_by=val_by,
                                   descriptors=descriptors)
    plan = plan_folds(dataset, by, assemblies, families)
    specs = []
    for kind, names in plan:
        specs += fold_specs(dataset, model_config, config, names, kind=kind,
                            models_dir=Path(out) / "models" if save_models else None)
    runner, how = _runner(no_ray, device, console)
    for kind, names in plan:
        console.print(f"{len(names)} {kind} folds ({', '.join(names)})")
    console.print(f"{recipe}: {describe(model_config, config)}; {how}")
    t0 = time.perf_counter()

    def on_fold(f):
        m = f["metrics"]
        console.print(f"  {f.get('kind', 'assembly')} {f['assembly']}: accuracy "
                      f"{100 * m['accuracy']:.1f}% (ceiling {100 * m.get('ceiling', float('nan')):.1f}%) "
                      f"on {m['rows']} rows ({f['seconds']:.0f} s)")

    from rap.commands._flags import flags
    from rap.model.evaluation.cross_validation import sequential_folds

    if runner is sequential_folds:  # in this process: a progress bar per fold
        import functools

        from rap.commands.train import progress_bar

        bar, on_step = progress_bar(console)
        with flags("max_rows"), bar:
            folds = cross_validate(specs, functools.partial(sequential_folds, on_step=on_step),
                                   on_fold)
    else:
        with flags("max_rows"):
            folds = cross_validate(specs, runner, on_fold)
    notes = {"dataset": str(Path(dataset).resolve()), "threshold": threshold, "epochs": epochs,
             "batch size": batch_size, "seed": seed, "run": how, "recipe": recipe,
             "model": describe(model_config, config),
             "wall time": f"{time.perf_counter() - t0:.0f} s"}
    paths = write_report(folds, out, f"Robustness CNN cross-validation: {name}", notes)
    for kind, _ in plan:
        mean = summary_rows([f for f in folds if f.get("kind", "assembly") == kind])[-1]
        typer.echo(f"leave-one-{kind}-out: mean accuracy {100 * mean['accuracy']:.2f}% (low "
                   f"robustness {100 * mean['low_accuracy']:.2f}%, high robustness "
                   f"{100 * mean['high_accuracy']:.2f}%; noise ceiling "
                   f"{100 * mean['ceiling']:.2f}%) over {len([f for f in folds if f.get('kind', 'assembly') == kind])} folds")
    typer.echo(f"wrote {', '.join(str(p) for p in paths)}")


def register(app: typer.Typer) -> None:
    app.command("evaluate")(evaluate_command)
