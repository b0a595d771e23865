"""``rap-farm check DATASET [--quarantine]``: does every shard of a dataset read?

Opens every shard (``rap.dataset.shard_problem``: the footer, the schema, every page of every
column), lists the corrupt ones with the reason, and counts the keys stored more than once and the
temporary files a writer left. ``--quarantine`` takes the dataset's one-writer lock (refused, exit
3, while a ``label`` runs), moves the corrupt shards to ``DATASET/_quarantine/NAME/`` (readers skip
``_`` paths) and removes the temporary files, so that rerunning the ``label`` command that wrote
the dataset refills exactly the rows they held.

Exit status: 0 when every shard reads (or every corrupt one was quarantined); 2 when corrupt
shards were found and left in place; 3 when ``--quarantine`` could not take the lock or move a
file. Reads the whole dataset once, a batch at a time; writes nothing without ``--quarantine``.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register", "check_command", "warn_duplicates"]


def warn_duplicates(dataset: Path) -> None:
    """One line on stderr when keys of ``dataset`` are stored more than once (readers then use
    each key's first row); nothing otherwise. Raises ``CorruptShardError`` for a shard that does
    not read."""
    from rap.dataset import duplicate_keys

    dup = duplicate_keys(dataset)
    if dup:
        typer.echo(f"rap-farm: warning: {dup.describe()}", err=True)


def check_command(
    dataset: Path = typer.Argument(..., help="Dataset directory written by `rap-farm label`."),
    quarantine: bool = typer.Option(
        False, "--quarantine",
        help="Move corrupt shards to DATASET/_quarantine/ (and remove leftover temporary files), "
             "so that rerunning `rap-farm label` refills their rows."),
) -> None:
    """Open every shard of DATASET, list the corrupt ones, and with --quarantine move them aside."""
    import pyarrow.parquet as pq

    from rap import dataset as ds
    from rap.errors import InputError

    if not dataset.is_dir():
        raise InputError(f"{dataset}: no such dataset directory")
    meta = ds.read_meta(dataset)  # InputError: a metadata file that does not read
    files = ds.shard_files(dataset)
    if meta is None and not files:
        raise InputError(f"{dataset}: not a rap-farm dataset ({ds.METADATA_FILE} and shards "
                         f"missing)")
    corrupt, rows = [], 0
    for p in files:
        why = ds.shard_problem(p)
        if why is None:
            rows += pq.read_metadata(p).num_rows
        else:
            corrupt.append((p, why))
    temporary = sorted([*dataset.glob(".tmp-*"), *dataset.glob("*/.tmp-*")])
    typer.echo(f"{dataset}: {len(files)} shards, {rows:,} rows in the {len(files) - len(corrupt)} "
               f"that read, {len(corrupt)} corrupt")
    for p, why in corrupt:
        typer.echo(f"corrupt      {p}: {why}")
    if quarantine and (corrupt or temporary):
        with ds.lock_dataset(dataset, "rap-farm check --quarantine"):
            for (p, _), dest in zip(corrupt, ds.quarantine(dataset, [p for p, _ in corrupt])):
                typer.echo(f"quarantined  {p} -> {dest}")
            removed = ds.clean_partial_files(dataset)
        if removed:
            typer.echo(f"removed      {removed} temporary files left by an interrupted writer")
        if corrupt:
            command = meta.command if meta is not None else ""
            again = (f"`{command}`" if command and len(command) <= 200 else
                     f"the `rap-farm label` command recorded in {dataset / ds.METADATA_FILE}")
            typer.echo(f"rerun {again} to label the rows they held again")
        corrupt = []
    elif temporary:
        typer.echo(f"temporary    {len(temporary)} .tmp-* files: a running writer's, or left by an "
                   f"interrupted one (the next `rap-farm label` or `check --quarantine` removes "
                   f"them)")
    if corrupt:
        raise InputError(f"{dataset}: {len(corrupt)} corrupt shard(s); `rap-farm check {dataset} "
                         f"--quarantine` moves them aside and a rerun of `rap-farm label` refills "
                         f"their rows")
    if ds.shard_files(dataset):
        dup = ds.duplicate_keys(dataset)
        if dup:
            typer.echo(f"duplicates   {dup.describe()}")


def register(app: typer.Typer) -> None:
    app.command("check")(check_command)
