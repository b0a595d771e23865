"""The ``rap-farm`` command line (typer).

Each command lives in ``rap.commands.<name>`` and registers itself with ``register(app)``; heavy
imports (ray, torch) happen inside the command bodies; a command module that cannot be imported is
an internal error (exit 4, naming the module), never a command silently missing. Errors derived
from ``RapError`` print one line to stderr and exit with their documented status (``rap.errors``: 1
for an infeasible plan, 2 for bad input, 3 for work that failed, 130 when interrupted). An
``OSError`` that reaches ``main`` (a file that cannot be written: disk full, read-only,
permissions) is one line naming the path, exit 3; any other exception is a bug in rap-farm: one
line, exit 4, never exit 1 (which means "no feasible sequence"). No traceback is shown unless
``RAP_DEBUG=1``.

SIGTERM (``docker stop``, systemd, Kubernetes, SLURM, ``ray job stop``) stops a command as Ctrl-C
does: ``main`` runs inside ``rap.errors.sigterm_as_interrupt`` (a handler that raises
``KeyboardInterrupt`` and ignores a second SIGTERM, so the cleanup after the first is not
interrupted), so every command keeps what it committed, prints one line and exits 130 (``serve``
installs its own: it drains and exits 0).
``rap.farm.runtime.init_ray`` puts the handler back after ``ray.init``, which replaces it.

Usage errors (a missing argument, an unknown option, a bad value) print the CLI stack's short usage
message and exit 2. The app runs with ``standalone_mode=False``, so the stack's own exceptions reach
``main``. Which classes those are depends on the versions installed: typer < 0.20 raises click's
(``click.exceptions.UsageError``...), later typers raise those of their vendored copy of click
(``typer._click.exceptions``...), so ``main`` recognises them by class name along the exception's
MRO (``ClickException``, ``Abort``, ``Exit`` defined in a ``click`` or ``typer`` module) and never
imports click itself. Supported and tested: see ``typer`` in pyproject.toml.
"""

from __future__ import annotations

import importlib
import os
import sys

import typer

from rap import __version__
from rap.errors import (EXIT_FAILED, EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, RapError,
                        sigterm_as_interrupt)

__all__ = ["app", "main", "register_commands"]

COMMAND_MODULES = ("inspect", "show", "generate", "simulate", "label", "check", "train",
                   "evaluate", "score", "plan", "serve", "experiment", "demo", "import_drawing",
                   "export", "execute")

app = typer.Typer(
    name="rap-farm",
    help="Robust 2D assembly sequencing: exact NDBG partitions, a physics robustness simulator, "
         "a Ray labelling farm and a CNN scorer (RAP).\n\nExit status: 0 ok, 1 no feasible "
         "sequence, 2 invalid input, 3 work failed (labelling, workers, disk full), 4 internal "
         "error, 130 interrupted.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts are plain: "[default: 8]" is text, not markup
)


def _version(value: bool):
    if value:
        typer.echo(f"rap-farm {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit.")):
    pass


def register_commands(target: typer.Typer, names=COMMAND_MODULES) -> dict[str, Exception]:
    """Import ``rap.commands.<name>`` for each name and register its commands on ``target``; the
    modules that cannot be imported, with their errors. ``main`` refuses to run with any (a broken
    install or a bug: one line, exit 4) rather than offer a CLI with a command silently missing."""
    broken: dict[str, Exception] = {}
    for name in names:
        try:
            module = importlib.import_module(f"rap.commands.{name}")
        except Exception as exc:
            broken[name] = exc
            continue
        module.register(target)
    return broken


_BROKEN = register_commands(app)


def _stack_exception(exc: BaseException) -> str | None:
    """``"usage"``, ``"abort"`` or ``"exit"`` when ``exc`` is one of the CLI stack's control
    exceptions (click's or typer's vendored copy, any version), else None."""
    for cls in type(exc).__mro__:
        module = getattr(cls, "__module__", "") or ""
        if module.split(".")[0] not in ("click", "typer"):
            continue
        if cls.__name__ == "ClickException":
            return "usage"
        if cls.__name__ == "Abort":
            return "abort"
        if cls.__name__ == "Exit":
            return "exit"
    return None


def _interrupted() -> None:
    print("rap-farm: interrupted; committed work is kept", file=sys.stderr)
    _forget_stale_interrupt()
    sys.exit(EXIT_INTERRUPTED)


def _forget_stale_interrupt() -> None:
    """Clear CPython's "unhandled KeyboardInterrupt" flag. A ``KeyboardInterrupt`` that leaves
    code run by ``exec`` of a string (a dataclass being made, a module being imported) sets it,
    although the CLI handles that interrupt; ``python -m`` then ends the process by SIGINT after
    its clean exit, and the caller sees it killed (status -2) instead of 130 (2 runs in 60 of
    ``plan`` stopped by SIGTERM, tests/farm/test_sigterm.py). Every ``exec`` of a string resets
    the flag first, and an empty one leaves it reset."""
    exec("", {})


def _internal_error(exc: BaseException, what: str = "") -> None:
    line = " ".join(str(exc).split())[:300]
    print(f"rap-farm: internal error: {what}{type(exc).__name__}: {line} (a bug in rap-farm "
          f"{__version__}; RAP_DEBUG=1 shows the traceback)", file=sys.stderr)
    sys.exit(EXIT_INTERNAL)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: runs the app and maps errors to one line + exit status."""
    with sigterm_as_interrupt():
        _main(argv)


def _main(argv: list[str] | None) -> None:
    if _BROKEN:
        name, exc = next(iter(_BROKEN.items()))
        if os.environ.get("RAP_DEBUG"):
            raise exc
        _internal_error(exc, f"command module rap.commands.{name} cannot be imported: ")
    try:
        status = app(args=argv, prog_name="rap-farm", standalone_mode=False)
    except RapError as exc:
        if os.environ.get("RAP_DEBUG"):
            raise
        print(f"rap-farm: error: {exc}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        _interrupted()
    except SystemExit:
        raise
    except Exception as exc:
        kind = _stack_exception(exc)
        if kind == "usage":  # typer's short usage message ("Usage: ... Error: ...")
            exc.show()  # type: ignore[attr-defined]
            sys.exit(EXIT_INPUT)
        if kind == "abort":  # click < 8.2 turns Ctrl-C into Abort
            _interrupted()
        if kind == "exit":
            sys.exit(getattr(exc, "exit_code", 0))
        if os.environ.get("RAP_DEBUG"):
            raise
        if isinstance(exc, OSError):
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            print(f"rap-farm: error: {where}{exc.strerror or exc} (nothing more was written)",
                  file=sys.stderr)
            sys.exit(EXIT_FAILED)
        if isinstance(exc, MemoryError):
            print("rap-farm: error: out of memory", file=sys.stderr)
            sys.exit(EXIT_FAILED)
        _internal_error(exc)
    # In non-standalone mode an Exit (--help, --version, typer >= 0.20's Ctrl-C as Exit(130)) is
    # returned as its status; commands themselves return None.
    if isinstance(status, int) and not isinstance(status, bool) and status:
        if status == EXIT_INTERRUPTED:
            _interrupted()
        sys.exit(status)


if __name__ == "__main__":
    main()
