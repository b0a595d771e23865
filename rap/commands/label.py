"""``rap-farm label``: label every operation of some assemblies on Ray into an Arrow dataset.

Ray is imported only inside the command body (through ``rap.farm.driver``).
"""

from __future__ import annotations

import shlex
import sys
from typing import List, Optional

import typer

from rap.seeds import DEFAULT_ROOT_SEED

__all__ = ["register", "label"]

PRESET_HELP = ("tiny: 20 trials, <= 12 operations per assembly (tests, demo); default: 100 trials, "
               "<= 2000 operations per assembly (a laptop training set); full: 100 trials, every "
               "operation. --trials and --max-ops-per-assembly override the preset.")


def label(
    assemblies: List[str] = typer.Argument(..., metavar="ASSEMBLY...", help="Assembly JSON files."),
    out: str = typer.Option(..., "--out", "-o", help="Dataset directory (created; resumed if it exists)."),
    address: Optional[str] = typer.Option(
        None, "--address",
        help="Join a Ray cluster: 'auto' or HOST:PORT (default: $RAY_ADDRESS, else start a local Ray "
             "with all cores)."),
    workers: Optional[int] = typer.Option(
        None, "--workers", "-w",
        help="The most simulation actors (one CPU each) to ask for: labelling starts on the first "
             "that runs, and an autoscaling cluster adds nodes for the rest (default: every CPU "
             "of the cluster, and those that join later; nothing asked of an autoscaler)."),
    preset: str = typer.Option("default", "--preset", help=PRESET_HELP),
    trials: Optional[int] = typer.Option(None, "--trials", help="Noisy trials per operation."),
    seed: int = typer.Option(DEFAULT_ROOT_SEED, "--seed", help="Root seed of the run."),
    max_ops: Optional[int] = typer.Option(
        None, "--max-ops-per-assembly",
        help="Label a seeded sample of at most K operations per assembly, drawn lazily from random "
             "disassembly trees (0: every operation; refused past a budget of "
             "100,000 per assembly)."),
    directions: int = typer.Option(
        1, "--directions-per-range",
        help="Operations per merged direction range: its middle, plus N - 1 seeded directions "
             "strictly inside it, each its own operation."),
    space: str = typer.Option(
        "all", "--space",
        help="Operation space, as in plan --space: all (every partition of every NDBG cell) | "
             "online (one partition per NDBG cell, as RAP)."),
    mode: Optional[str] = typer.Option(None, "--mode", hidden=True,
                                       help="Deprecated name of --space."),
    flush_rows: int = typer.Option(512, "--flush-rows", help="Commit a shard every N rows..."),
    flush_seconds: float = typer.Option(30.0, "--flush-seconds", help="...or every T seconds."),
    start_timeout: float = typer.Option(
        120.0, "--start-timeout", min=1.0,
        help="Seconds until at least one simulation worker runs (a head without CPUs waits for "
             "a node: minutes on a cloud) before the run ends with exit status 3; also how long "
             "a run may go on with no worker left (all nodes lost)."),
    progress_timeout: float = typer.Option(
        600.0, "--progress-timeout", min=1.0,
        help="Seconds without a completed batch after which a batch lost with its worker (node "
             "lost, actor unreachable) is no longer resubmitted and its assembly fails; while "
             "batches complete, lost ones are resubmitted whatever their number."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Label operations (simulated success rate + start/goal images) into a Parquet dataset."""
    from rap.commands._flags import flags
    from rap.enumerate import MODES
    from rap.errors import InputError

    if mode is not None:  # --mode: the old name of --space, kept working
        if space != "all" and space != mode:
            raise InputError(f"--mode {mode!r} and --space {space!r}: --mode is the old name of "
                             f"--space; give --space only")
        space = mode
    if space not in MODES:
        flag = "--space" if mode is None else "--mode"
        raise InputError(f"{flag} {space!r}: choose {' or '.join(MODES)}")
    from rap.farm import driver  # imports ray

    if preset not in driver.PRESETS:
        raise InputError(f"--preset must be one of {', '.join(driver.PRESETS)}, not {preset!r}")
    p_trials, p_max = driver.PRESETS[preset]
    if max_ops == 0:
        max_ops_eff = None
    elif max_ops is None:
        max_ops_eff = p_max
    else:
        max_ops_eff = max_ops
    cfg = driver.LabelConfig(
        assemblies=tuple(assemblies), out=out, address=address, workers=workers,
        trials=trials if trials is not None else p_trials, seed=seed,
        max_ops_per_assembly=max_ops_eff, directions_per_range=directions, mode=space,
        flush_rows=flush_rows, flush_seconds=flush_seconds, start_timeout_s=start_timeout,
        progress_timeout_s=progress_timeout,
        progress=not quiet and sys.stderr.isatty(),
        command=" ".join(shlex.quote(a) for a in ["rap-farm", *sys.argv[1:]]))
    with flags(limit="--max-ops-per-assembly"):  # TooManyOperations: uncapped, too large
        plan = driver.prepare(cfg)
    typer.echo(f"{plan.total_text} operations selected in {len(plan.assemblies)} assemblies "
               f"({plan.existing_rows} rows already in {out}); labelling what is missing", err=True)
    summary = driver.run_label(cfg, plan)
    typer.echo(driver.format_summary(summary, no_limit="--max-ops-per-assembly 0"))
    if summary.failed:
        from rap.farm.pool import FarmError

        names = ", ".join(sorted(summary.failed))
        raise FarmError(f"labelling failed for {len(summary.failed)} of {len(plan.assemblies)} "
                        f"assemblies ({names}); the rows committed for every assembly are kept")


def register(app: typer.Typer) -> None:
    app.command("label")(label)
