"""The robot cell's flags, shared by ``rap-farm plan`` and ``rap-farm experiment``.

``BASE``, ``LINEAR``, ``DIRECTIONS``, ``GRAVITY``, ``FRICTION``, ``LAYERS``: the typer options
(one home for their names; their help is ``rap.plan.cell.help.CELL_HELP``, which the service
and the page show too; docs/PLANNING.md, "Robot-cell constraints");
``cell_constraints(...)`` reads them into a ``rap.plan.cell.constraints.CellConstraints``, a bad value
becoming one line naming its flag (exit 2); ``check_cell(cell, assemblies)`` checks them against
the assemblies (``--base`` must name a part of each).
"""

from __future__ import annotations

import typer

from rap.plan.cell.help import CELL_HELP

__all__ = ["BASE", "LINEAR", "DIRECTIONS", "GRAVITY", "FRICTION", "LAYERS", "cell_constraints",
           "check_cell"]

BASE = typer.Option(None, "--base", help=CELL_HELP["base"])
LINEAR = typer.Option(False, "--linear", help=CELL_HELP["linear"])
DIRECTIONS = typer.Option(None, "--directions", help=CELL_HELP["directions"])
GRAVITY = typer.Option(None, "--gravity", help=CELL_HELP["gravity"])
FRICTION = typer.Option(None, "--friction", help=CELL_HELP["friction"])
LAYERS = typer.Option(False, "--layers", help=CELL_HELP["layers"])


def cell_constraints(base, linear, directions, gravity, friction, layers):
    """The ``CellConstraints`` of the flags' values; ``InputError`` naming the flag."""
    from rap.commands._flags import flags
    from rap.plan.cell.constraints import CellConstraints

    with flags("base", "linear", "directions", "gravity", "friction", "layers"):
        return CellConstraints.parse(base, linear, directions, gravity, friction, layers)


def check_cell(cell, assemblies) -> None:
    """``cell.check`` on each assembly (``--base`` names one of its parts); ``InputError`` naming
    ``--base`` otherwise."""
    from rap.commands._flags import flags

    with flags("base"):
        for asm in assemblies:
            cell.check(asm)
