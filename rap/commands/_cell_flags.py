"""The robot cell's flags, shared by ``rap-farm plan`` and ``rap-farm experiment``.

``BASE``, ``LINEAR``, ``DIRECTIONS``, ``GRAVITY``, ``FRICTION``, ``LAYERS``: the typer options
(one home for their names and help; docs/PLANNING.md, "Robot-cell constraints");
``cell_constraints(...)`` reads them into a ``rap.plan.constraints.CellConstraints``, a bad value
becoming one line naming its flag (exit 2); ``check_cell(cell, assemblies)`` checks them against
the assemblies (``--base`` must name a part of each).
"""

from __future__ import annotations

import typer

__all__ = ["BASE", "LINEAR", "DIRECTIONS", "GRAVITY", "FRICTION", "LAYERS", "cell_constraints",
           "check_cell"]

BASE = typer.Option(None, "--base", help="Part fixed in the fixture from the start: it never "
                    "moves (every step's fixed side holds it).")
LINEAR = typer.Option(False, "--linear", help="One arm: every step moves one part.")
DIRECTIONS = typer.Option(None, "--directions", help="DX,DY:DEG: insertion directions within "
                          "DEG degrees of (DX,DY), e.g. 0,-1:30 (repeatable: any of the cones).")
GRAVITY = typer.Option(None, "--gravity", help="DX,DY: gravity in the drawing's plane (needs "
                       "--base): every intermediate assembly stands statically on the base; "
                       "e.g. 0,-1.")
FRICTION = typer.Option(None, "--friction", help="Coulomb friction at the contacts with "
                        "--gravity [default: 0.5].")
LAYERS = typer.Option(False, "--layers", help="With --gravity: build in layers, a part only "
                      "after every part lying wholly below it (a wall course by course).")


def cell_constraints(base, linear, directions, gravity, friction, layers):
    """The ``CellConstraints`` of the flags' values; ``InputError`` naming the flag."""
    from rap.commands._flags import flags
    from rap.plan.constraints import CellConstraints

    with flags("base", "linear", "directions", "gravity", "friction", "layers"):
        return CellConstraints.parse(base, linear, directions, gravity, friction, layers)


def check_cell(cell, assemblies) -> None:
    """``cell.check`` on each assembly (``--base`` names one of its parts); ``InputError`` naming
    ``--base`` otherwise."""
    from rap.commands._flags import flags

    with flags("base"):
        for asm in assemblies:
            cell.check(asm)
