"""The ``rap-farm`` command line (typer).

Each command lives in ``rap.commands.<name>`` and registers itself with ``register(app)``; heavy
imports (ray, torch) happen inside the command bodies. Errors derived from ``RapError`` print one
line to stderr and exit with their documented status (2 for bad input, 1 for an infeasible plan,
130 when interrupted); no traceback is shown unless ``RAP_DEBUG=1``.
"""

from __future__ import annotations

import importlib
import os
import sys

import typer

from rap import __version__
from rap.errors import EXIT_INTERRUPTED, RapError

__all__ = ["app", "main"]

COMMAND_MODULES = ("inspect", "show", "generate", "simulate", "label", "train", "evaluate",
                   "score", "plan", "experiment", "demo")

app = typer.Typer(
    name="rap-farm",
    help="Robust 2D assembly sequencing: exact NDBG partitions, a physics robustness simulator, "
         "a Ray labelling farm and a CNN scorer (RAP).\n\nExit status: 0 ok, 1 no feasible "
         "sequence, 2 invalid input, 130 interrupted.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool):
    if value:
        typer.echo(f"rap-farm {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit.")):
    pass


for _name in COMMAND_MODULES:
    try:
        _mod = importlib.import_module(f"rap.commands.{_name}")
    except ModuleNotFoundError as exc:  # a command whose module is not written yet
        if exc.name != f"rap.commands.{_name}":
            raise
        continue
    _mod.register(app)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: runs the app and maps errors to one line + exit status."""
    try:
        app(args=argv, standalone_mode=False)
    except RapError as exc:
        if os.environ.get("RAP_DEBUG"):
            raise
        print(f"rap-farm: error: {exc}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        print("rap-farm: interrupted; committed work is kept", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except SystemExit:
        raise
    except Exception as exc:  # click usage errors come through here in non-standalone mode
        import click

        if isinstance(exc, click.exceptions.ClickException):
            exc.show()
            sys.exit(2)
        if isinstance(exc, click.exceptions.Abort):
            sys.exit(EXIT_INTERRUPTED)
        raise


if __name__ == "__main__":
    main()
