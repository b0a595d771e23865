"""``rap-farm show``: a picture of an assembly and its NDBG circle."""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register"]


def show(
    assembly: Path = typer.Argument(..., help="Assembly JSON file."),
    out: Path = typer.Option(..., "-o", "--out", help="Picture to write (.png or .svg)."),
) -> None:
    """Draw the assembly with part ids and its NDBG circle of removal directions (removal =
    -insertion, the direction plan shows), arcs shaded by how many partitions of the whole
    assembly they admit."""
    from rap.io import load_assembly
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.partitions import cell_partition_counts
    from rap.render.pictures import assembly_figure

    asm = load_assembly(assembly)
    ndbg = build_ndbg(asm)
    counts = cell_partition_counts(ndbg, frozenset(asm.ids))
    path = assembly_figure(asm, ndbg.cells, counts, out)
    typer.echo(f"wrote {path}")


def register(app: typer.Typer) -> None:
    app.command("show")(show)
