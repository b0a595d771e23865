"""``rap-farm evaluate``: leave-one-assembly-out cross-validation (the paper's Table I)."""

from __future__ import annotations

import os
from pathlib import Path

import typer

__all__ = ["register", "evaluate_command"]


def _runner(no_ray: bool, device: str, console):
    """Ray tasks when allowed, available and useful (several cores or a cluster address, CPU
    training); otherwise the folds run one after the other in this process."""
    from rap.model.evaluate import sequential_folds
    from rap.model.predict import resolve_device

    if no_ray:
        return sequential_folds, "in-process (--no-ray)"
    if resolve_device(device).type != "cpu":
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
):
    """Train one model per held-out assembly and write accuracy tables, calibration and a plot."""
    import time

    from rap.commands._console import console as make_console

    from rap.errors import InputError
    from rap.model.cnn import ModelConfig, RobustnessCNN
    from rap.model.evaluate import cross_validate, fold_specs, summary_rows, write_report
    from rap.model.train import TrainConfig, dataset_assemblies

    console = make_console(stderr=True)
    name = Path(dataset).resolve().name
    out = out or Path("reports") / name
    names = dataset_assemblies(dataset)
    if len(names) < 2:
        raise InputError(f"{dataset}: leave-one-assembly-out needs at least two assemblies "
                         f"(has: {', '.join(names)})")
    config = TrainConfig(epochs=epochs, batch_size=batch_size, seed=seed, device=device,
                         threshold=threshold)
    model_config = ModelConfig()
    specs = fold_specs(dataset, model_config, config, names,
                       models_dir=Path(out) / "models" if save_models else None)
    runner, how = _runner(no_ray, device, console)
    console.print(f"{len(specs)} folds ({', '.join(names)}), {epochs} epochs each, {how}")
    t0 = time.perf_counter()

    def on_fold(f):
        m = f["metrics"]
        console.print(f"  {f['assembly']}: accuracy {100 * m['accuracy']:.1f}% on {m['rows']} rows "
                      f"({f['seconds']:.0f} s)")

    folds = cross_validate(specs, runner, on_fold)
    notes = {"dataset": str(Path(dataset).resolve()), "threshold": threshold, "epochs": epochs,
             "batch size": batch_size, "seed": seed, "run": how,
             "model": f"{RobustnessCNN(model_config).num_parameters():,} parameters, channels "
                      f"{list(model_config.channels)}, hidden {list(model_config.hidden)}",
             "loss": "cross-entropy weighted by inverse class frequency of the training rows",
             "wall time": f"{time.perf_counter() - t0:.0f} s"}
    paths = write_report(folds, out, f"Robustness CNN, leave-one-assembly-out: {name}", notes)
    mean = summary_rows(folds)[-1]
    typer.echo(f"mean accuracy {100 * mean['accuracy']:.2f}% (low robustness "
               f"{100 * mean['low_accuracy']:.2f}%, high robustness "
               f"{100 * mean['high_accuracy']:.2f}%) over {len(folds)} folds")
    typer.echo(f"wrote {', '.join(str(p) for p in paths)}")


def register(app: typer.Typer) -> None:
    app.command("evaluate")(evaluate_command)
