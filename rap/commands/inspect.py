"""``rap-farm inspect ASSEMBLY [--json] [--max-partitions N]``: parts, NDBG and partition counts.

``--json`` prints exactly ``{"assembly": name, "parts": [ids], "cells": [{"kind": "vertex"|"arc",
"direction": [dx, dy], "blocks": [[a, b], ...]}, ...]}``: cells CCW from angle 0, ``direction``
the float unit removal direction (an arc's middle, a vertex's critical direction; removal =
-insertion, the direction ``plan`` shows), ``[a, b]`` (part ids, sorted) meaning that translating
part a alone along it collides with part b. The NDBG and the counts show a transient progress line
on stderr (a terminal only).
Invalid input raises ``AssemblyError`` (one line on stderr, exit status 2).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

__all__ = ["register", "inspect_json", "inspect_counts"]


def inspect_json(assembly, ndbg) -> dict:
    """The ``--json`` document of an assembly and its NDBG."""
    ids = ndbg.ids
    cells = []
    for c in ndbg.cells:
        blocks = sorted([ids[i], ids[j]] for i, j in c.blocks)
        cells.append({"kind": c.kind, "direction": [c.unit[0], c.unit[1]], "blocks": blocks})
    return {"assembly": assembly.name, "parts": list(ids), "cells": cells}


def _count(fn, budget_text):
    """fn(), or ``budget_text`` (None: the budget error's message) when a budget is exceeded."""
    from rap.geometry.moving_sets import TooManyPartitions

    try:
        return fn()
    except TooManyPartitions as exc:
        return str(exc) if budget_text is None else budget_text


def inspect_counts(ndbg, max_partitions: int = 100_000, max_subassemblies: int = 2_000) -> dict:
    """Counts shown by ``inspect`` (strings like '> N' where a budget was exceeded)."""
    from rap.geometry.andor import and_or_graph
    from rap.geometry.partitions import all_partitions, online_partitions

    whole = ndbg.ids
    counts: dict = {
        "cells": len(ndbg.cells),
        "vertex cells": sum(c.kind == "vertex" for c in ndbg.cells),
        "arc cells": sum(c.kind == "arc" for c in ndbg.cells),
        "online partitions of the whole": len(online_partitions(ndbg, whole)),
        "all partitions of the whole": _count(
            lambda: len(all_partitions(ndbg, whole, max_count=max_partitions)),
            f"> {max_partitions}"),
    }
    locked: set = set()
    complete = True
    for mode in ("online", "all"):
        def run(mode=mode):
            return and_or_graph(ndbg, mode, max_subassemblies=max_subassemblies,
                                max_count=max_partitions, max_operations=max_partitions)

        whole_too_many = isinstance(counts["all partitions of the whole"], str)
        if mode == "all" and whole_too_many:
            g = f"more than {max_partitions} operations"
        else:
            g = _count(run, None)
        if isinstance(g, str):
            counts[f"reachable subassemblies ({mode})"] = "search stopped"
            counts[f"operations over the AND/OR graph ({mode})"] = g
            complete = False
        else:
            counts[f"reachable subassemblies ({mode})"] = g.n_subassemblies
            counts[f"operations over the AND/OR graph ({mode})"] = g.n_operations
            locked.update(g.interlocked)
    counts["interlocked subassemblies"] = sorted(sorted(s) for s in locked)
    counts["search complete"] = complete
    return counts


def register(app: typer.Typer) -> None:
    @app.command("inspect")
    def inspect_cmd(
        assembly_file: Path = typer.Argument(..., metavar="ASSEMBLY", help="Assembly JSON file."),
        as_json: bool = typer.Option(False, "--json", help="Print the NDBG cells as JSON."),
        max_partitions: int = typer.Option(100_000, "--max-partitions", min=1,
                                           help="Budget for enumerating all partitions."),
        max_subassemblies: int = typer.Option(2_000, "--max-subassemblies", min=1,
                                              help="Budget of composite subassemblies per "
                                                   "AND/OR graph."),
    ):
        """Validate an assembly exactly and summarise its NDBG and partitions."""
        from rap.io import load_assembly
        from rap.geometry.ndbg import build_ndbg

        from rap.commands._progress import activity

        with activity(f"inspecting {Path(assembly_file).name}") as progress:
            progress.update("reading the assembly")
            asm = load_assembly(assembly_file)
            progress.update("building the NDBG")
            ndbg = build_ndbg(asm)
            if not as_json:
                progress.update("counting partitions and AND/OR graphs")
                counts = inspect_counts(ndbg, max_partitions, max_subassemblies)
        if as_json:
            typer.echo(json.dumps(inspect_json(asm, ndbg)))
            return
        _human(asm, ndbg, counts)


def _human(asm, ndbg, counts) -> None:
    from rap.commands._console import console as make_console
    from rich.table import Table

    con = make_console()
    parts = Table(title=f"{asm.name}: {len(asm)} parts ({asm.source})")
    for col in ("id", "vertices", "holes", "area"):
        parts.add_column(col, justify="left" if col == "id" else "right")
    for p in asm.parts:
        area = p.area()
        parts.add_row(p.id, str(len(p.outer) + sum(len(h) for h in p.holes)), str(len(p.holes)),
                      str(area) if area.denominator == 1 else f"{float(area):.6g}")
    con.print(parts)
    nd = Table(title="NDBG (removal directions, CCW from +x; removal = -insertion, the direction "
                     "plan shows)")
    nd.add_column("cell", justify="right")
    nd.add_column("kind")
    nd.add_column("removal", justify="right")
    nd.add_column("blocking pairs", justify="right")
    shown = ndbg.cells if len(ndbg.cells) <= 24 else ndbg.cells[:24]
    for k, c in enumerate(shown):
        nd.add_row(str(k), c.kind, f"({c.unit[0]:+.3f}, {c.unit[1]:+.3f})", str(len(c.blocks)))
    if len(shown) < len(ndbg.cells):
        nd.add_row("...", f"{len(ndbg.cells) - len(shown)} more", "", "")
    con.print(nd)
    ct = Table(title="Counts")
    ct.add_column("quantity")
    ct.add_column("value", justify="right")
    for k, v in counts.items():
        if k in ("interlocked subassemblies", "search complete"):
            continue
        ct.add_row(k, str(v))
    con.print(ct)
    locked = counts["interlocked subassemblies"]
    if locked:
        con.print("interlocked subassemblies: " + "; ".join("{" + ",".join(s) + "}" for s in locked))
    else:
        con.print("interlocked subassemblies: none found"
                  + ("" if counts["search complete"] else " (search stopped at a budget)"))
