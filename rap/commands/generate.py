"""``rap-farm generate``: write synthetic assemblies for scaling experiments.

``rap-farm generate grid --k K [--size S] -o FILE`` and
``rap-farm generate tiling --parts N --seed S -o FILE`` (exact integer coordinates, validated).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from rap.errors import InputError

__all__ = ["register"]


def _write(assembly, out: Path) -> None:
    from rap.assembly import assembly_to_json

    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(out.name + ".tmp")
        tmp.write_text(json.dumps(assembly_to_json(assembly), indent=1) + "\n", encoding="utf-8")
        tmp.replace(out)
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc}") from None
    typer.echo(f"wrote {out} ({len(assembly)} parts)")


def register(app: typer.Typer) -> None:
    gen = typer.Typer(help="Generate synthetic assemblies (grids, random tilings).",
                      no_args_is_help=True)

    @gen.command("grid")
    def grid_cmd(k: int = typer.Option(..., "--k", min=1, help="Squares per side."),
                 size: int = typer.Option(10, "--size", min=1, help="Side of a square."),
                 output: Path = typer.Option(..., "-o", "--output", help="Output JSON file.")):
        """k x k grid of touching squares."""
        from rap.geometry.generate import grid

        _write(grid(k, size), output)

    @gen.command("tiling")
    def tiling_cmd(parts: int = typer.Option(..., "--parts", min=1, help="Number of parts."),
                   seed: int = typer.Option(0, "--seed", help="Random seed."),
                   output: Path = typer.Option(..., "-o", "--output", help="Output JSON file.")):
        """Random tiling: a jittered grid of convex quads."""
        import numpy as np

        from rap.geometry.generate import random_tiling

        _write(random_tiling(parts, np.random.default_rng(seed)), output)

    app.add_typer(gen, name="generate")
