"""The robot cell's parameters in words: one home for the help of ``rap-farm plan``'s cell flags
(``rap.commands._cell_flags``), the service's ``"constraints"`` schema (``rap.serve.api``) and the
planning page's tooltips (which read them from ``/openapi.json``).

``CELL_HELP``: parameter (``rap.plan.cell.constraints.CellConstraints``' fields, the keys of its JSON
form) -> one line. No imports: the CLI reads it at startup.
"""

from __future__ import annotations

__all__ = ["CELL_HELP"]

CELL_HELP = {
    "base": "Part fixed in the fixture from the start: it never moves (every step's fixed side "
            "holds it).",
    "linear": "One arm: every step moves one part.",
    "directions": "DX,DY:DEG: insertion directions within DEG degrees of (DX,DY), e.g. 0,-1:30 "
                  "(repeatable: any of the cones).",
    "gravity": "DX,DY: gravity in the drawing's plane (needs --base): every intermediate "
               "assembly stands statically on the base; e.g. 0,-1.",
    "friction": "Coulomb friction at the contacts with --gravity [default: 0.5].",
    "layers": "With --gravity: build in layers, a part only after every part lying wholly below "
              "it (a wall course by course).",
}
