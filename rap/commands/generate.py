"""``rap-farm generate``: write synthetic assemblies (scaling grids, random tilings, families).

``rap-farm generate grid --k K [--size S] -o FILE`` and
``rap-farm generate tiling --parts N --seed S -o FILE`` (exact integer coordinates, validated);
``rap-farm generate FAMILY --seed S [--OPTION VALUE ...] -o FILE`` for every family of
``rap.geometry.families`` (one sub-command each, built from the registry: an option left out is
drawn per seed; the held-out shape kinds of ``ALL_FAMILIES`` too, marked in the list), and ``rap-farm generate list`` to print the families with their options.

Family option values are read by the registry (``Option.parse``): a bad value is one line on
stderr naming the family and the flag (the registry names the option: ``rap.commands._flags``) and
exit status 2, never a traceback.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import Optional

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


def _output_option():
    """Every generator's output file: ``-o``/``--out`` as every other command, ``--output`` too."""
    return typer.Option(..., "-o", "--out", "--output",
                        help="Output JSON file (--output: the same).")


def _option_help(option) -> str:
    allowed = ", ".join(option.choices) if option.choices else f"{option.low}..{option.high}"
    if option.default is not None:
        default = f"default {option.default}"
    else:
        d = option.drawn
        default = "drawn per seed from " + (", ".join(d) if option.choices else f"{d[0]}..{d[-1]}")
    return f"{option.help} [{allowed}; {default}]"


def _family_command(gen: typer.Typer, family) -> None:
    """One sub-command for ``family``: --seed, one option per family option, -o."""
    kw = inspect.Parameter.KEYWORD_ONLY
    params = [inspect.Parameter("seed", kw, annotation=str, default=typer.Option(
        "0", "--seed", metavar="INT", help="Random seed: np.random.default_rng(seed)."))]
    for o in family.options:
        params.append(inspect.Parameter(o.name, kw, annotation=Optional[str], default=typer.Option(
            None, f"--{o.name.replace('_', '-')}", metavar="INT" if o.kind == "int" else "CHOICE",
            help=_option_help(o), show_default=False)))
    params.append(inspect.Parameter("output", kw, annotation=Path, default=_output_option()))

    def command(**values):
        from rap.commands._flags import flags
        from rap.geometry.families import generate

        seed = values.pop("seed")
        out = values.pop("output")
        try:
            seed = int(seed)
        except ValueError:
            raise InputError(f"{family.name}: --seed {seed!r}: must be an integer") from None
        with flags("seed", *(o.name for o in family.options), prefix=f"{family.name}: "):
            opts = {o.name: o.parse(values[o.name]) for o in family.options
                    if values.get(o.name) is not None}
            asm = generate(family.name, seed, **opts)
        _write(asm, out)

    command.__signature__ = inspect.Signature(params)
    command.__annotations__ = {p.name: p.annotation for p in params}
    command.__doc__ = family.description
    gen.command(family.name, help=f"{family.description} (family; see 'generate list').")(command)


def _list() -> None:
    from rich.table import Table

    from rap.commands._console import console
    from rap.geometry.families import ALL_FAMILIES

    table = Table(title="Assembly families: rap-farm generate FAMILY --seed S [--OPTION VALUE] -o FILE",
                  title_justify="left", show_lines=True)
    for col in ("family", "parts", "description", "options (allowed; default)"):
        table.add_column(col, overflow="fold")
    for f in ALL_FAMILIES.values():
        lo, hi = f.part_range()
        held = "" if f.training else " (held out: never used for training)"
        table.add_row(f.name, f"{lo}-{hi}", f.description + held,
                      "\n".join(f"--{o.name.replace('_', '-')} {o.describe().split('=', 1)[1]}"
                                for o in f.options))
    console().print(table)


def register(app: typer.Typer) -> None:
    gen = typer.Typer(help="Generate synthetic assemblies: grids, random tilings, and the assembly "
                           "families ('generate list' prints them with their options).",
                      no_args_is_help=True)

    @gen.command("grid")
    def grid_cmd(k: int = typer.Option(..., "--k", min=1, help="Squares per side."),
                 size: int = typer.Option(10, "--size", min=1, help="Side of a square."),
                 output: Path = _output_option()):
        """k x k grid of touching squares."""
        from rap.geometry.families.simple import grid

        _write(grid(k, size), output)

    @gen.command("tiling")
    def tiling_cmd(parts: int = typer.Option(..., "--parts", min=1, help="Number of parts."),
                   seed: int = typer.Option(0, "--seed", help="Random seed."),
                   output: Path = _output_option()):
        """Random tiling: a jittered grid of convex quads."""
        import numpy as np

        from rap.geometry.families.simple import random_tiling

        _write(random_tiling(parts, np.random.default_rng(seed)), output)

    @gen.command("list")
    def list_cmd():
        """List the assembly families with their part counts and options."""
        _list()

    from rap.geometry.families import ALL_FAMILIES

    for family in ALL_FAMILIES.values():  # the held-out shape kinds too (never trained on)
        _family_command(gen, family)

    app.add_typer(gen, name="generate")
