"""The rich consoles of the CLI: 120 columns when output is not a terminal (pipes, files, CI),
so tables of part ids do not wrap at rich's 80-column fallback."""

from __future__ import annotations

import sys

from rich.console import Console

__all__ = ["console"]


def console(stderr: bool = False) -> Console:
    stream = sys.stderr if stderr else sys.stdout
    return Console(stderr=stderr, width=None if stream.isatty() else 120)
