"""``rap-farm experiment``: the paper's planning comparison on a labelled dataset.

For each assembly of DATASET (found as ``--assemblies DIR/NAME.json``), a CNN that has not seen it
(``--models DIR/holdout-NAME.pt``, trained when absent; or ``--model CKPT`` for every assembly,
refused for an assembly the checkpoint was trained on), and RAP vs the sim-only baseline vs the
optimum vs the mean of 50 random sequences: robustness and planning time (cold score cache). The
simulator runs on the Ray pool (local Ray, or ``--address``). Writes ``OUT/results.md``,
``OUT/results.json`` and ``OUT/scores.png``. While it runs, a transient progress line on stderr
(a terminal only) shows the latest step; the log lines print above it.
"""

from __future__ import annotations

from pathlib import Path

import typer

from rap.commands._cell_flags import (BASE, DIRECTIONS, FRICTION, GRAVITY, LAYERS, LINEAR,
                                     cell_constraints, check_cell)

__all__ = ["register", "experiment_command"]


def experiment_command(
    dataset: Path = typer.Argument(..., help="Dataset directory written by `rap-farm label`."),
    out: Path = typer.Option(None, "--out", "-o", help="Report directory [default: reports/<dataset>]."),
    assemblies: list[Path] = typer.Option([Path("assemblies")], "--assemblies",
                                          help="Directory with NAME.json for the dataset's "
                                               "assemblies (repeatable; first match wins)."),
    models: Path = typer.Option(Path("models"), "--models",
                                help="Directory of holdout-NAME.pt / holdout-family-FAMILY.pt "
                                     "checkpoints (trained when absent)."),
    model: Path = typer.Option(None, "--model",
                               help="One checkpoint for every assembly instead of hold-out "
                                    "models (e.g. rap/data/default_model.pt on assemblies it was "
                                    "not trained on; refused for any it was)."),
    only: list[str] = typer.Option(None, "--only", help="Only these assemblies (repeatable)."),
    methods: str = typer.Option("random,rap,sim,optimal", "--methods",
                                help="Comma-separated: random, rap, rap-kK (fallback to the K "
                                     "most likely candidates), rap-pP (high at P(high) >= P%), "
                                     "rap-kK-pP, sim, optimal, search, search-wW-sN-tP."),
    epochs: int = typer.Option(8, "--epochs", min=1, help="Epochs for the hold-out CNNs."),
    trials: int = typer.Option(None, "--trials", min=1,
                               help="Simulator trials [default: the dataset's]."),
    address: str = typer.Option(None, "--address", help="Join this Ray cluster."),
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation actors [default: all CPUs]."),
    start_timeout: float = typer.Option(120.0, "--start-timeout", min=1.0,
                                        help="Seconds the simulation actors may take to start."),
    # the robot cell's constraints, for every assembly and method (as rap-farm plan's)
    base: str = BASE, linear: bool = LINEAR, directions: list[str] = DIRECTIONS,
    gravity: str = GRAVITY, friction: float = FRICTION, layers: bool = LAYERS,
):
    """Compare RAP, sim-only, optimal and random planning on every assembly (paper, section 8)."""
    from rap.io import load_assembly
    from rap.errors import InputError, ParameterError
    from rap.model.training.trainset import dataset_assemblies
    from rap.experiment.run import (EXPERIMENT_METHODS, check_held_out, method_planner,
                                     run_experiment)
    from rap.experiment.report import write_report

    cell = cell_constraints(base, linear, directions, gravity, friction, layers)
    if not (Path(dataset) / "_rapfarm.json").is_file():
        raise InputError(f"{dataset}: not a rap-farm dataset (no _rapfarm.json)")
    wanted = [m.strip() for m in methods.split(",") if m.strip()]
    if not wanted:
        raise InputError(f"--methods: choose from {', '.join(EXPERIMENT_METHODS)}, rap-kK-pP or "
                         f"search-...")
    for m in wanted:
        try:
            method_planner(m)
        except ParameterError as exc:  # the library names the parameter: here, the flag
            raise InputError(exc.for_name("--methods")) from None
    names = dataset_assemblies(dataset)
    if only:
        missing = sorted(set(only) - set(names))
        if missing:
            raise InputError(f"--only: {', '.join(missing)} not in {dataset} (has {', '.join(names)})")
        names = [n for n in names if n in only]
    files = []
    for n in names:
        found = [Path(d) / f"{n}.json" for d in assemblies if (Path(d) / f"{n}.json").is_file()]
        if not found:
            raise InputError(f"--assemblies {', '.join(map(str, assemblies))}: {n}.json is missing")
        files.append(found[0])
    asms = [load_assembly(f) for f in files]
    check_cell(cell, asms)
    out = out or Path("reports") / Path(dataset).resolve().name
    loaded = None  # the checkpoint, read once: checked here, before Ray starts, and planned with
    if model is not None:
        if not Path(model).is_file():
            raise InputError(f"--model {model}: no such checkpoint")
        try:
            loaded = check_held_out(model, asms)
        except ParameterError as exc:
            raise InputError(f"{exc.for_name('--model')} (use --models for hold-out "
                             f"models)") from None

    import rap.serve.planning as service
    from rap.farm.pool import SimPool
    from rap.farm.runtime import connect

    from rap.commands._progress import activity

    with connect(address) as rt, activity(f"experiment on {Path(dataset).name}") as progress:
        def log(line: str) -> None:
            typer.echo(line)
            progress.update(" ".join(str(line).split())[:90])

        progress.update(f"starting {workers or rt.cpus} simulation workers")
        pool = SimPool(workers or rt.cpus)
        try:
            pool.ready(start_timeout)
            rows = run_experiment(dataset, asms, sim_backend=service.PoolSimulator(pool),
                                  models_dir=models, epochs=epochs, trials=trials,
                                  methods=wanted, log=log, model=model, constraints=cell,
                                  loaded_model=loaded)
        finally:
            pool.shutdown()
    notes = {"dataset": str(dataset), "simulation workers": workers or rt.cpus,
             "models": (f"{model} for every assembly" if model is not None
                        else f"hold-out models from {models}"),
             "methods": ", ".join(wanted), "timing": "each method's search with a cold score cache"}
    if cell.active:
        from rap.plan.cell.constraints import SCORE_NOTE

        notes["cell constraints"] = f"{cell.describe()} ({SCORE_NOTE})"
    paths = write_report(rows, out, f"Planning experiment on {Path(dataset).name}", notes)
    typer.echo((Path(out) / "results.md").read_text())
    for p in paths:
        typer.echo(f"wrote {p}")


def register(app: typer.Typer) -> None:
    app.command("experiment")(experiment_command)
