"""``rap-farm import DRAWING.dxf|DRAWING.svg -o ASSEMBLY.json``: a CAD drawing as an assembly file.

Options: ``--units`` (the output unit: mm, cm, m, in; default mm), ``--tolerance`` (the chordal
tolerance and grid step, in that unit; default 0.01), ``--parts auto|face|loop|layer`` (default
auto: annotations left out, a part per closed loop or per face of cut lines), ``--scale S``
(output units per SVG user unit; default a CSS px where the SVG states no physical size),
``--layers A,B`` and ``--skip-layers C`` (DXF layers, SVG top-level groups). The work is ``rap.cad.import_drawing``; this module checks the
options, writes the validated assembly atomically (a temporary file beside it, fsync'ed, with the
user's umask, renamed into place: the file appears whole or not at all) and prints the summary.
Exit status 2 with one line for a bad drawing or option (nothing is written), 3 when the file
cannot be written (the path is named, no temporary file is left).
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path
from typing import Optional

import typer

from rap.errors import InputError, StorageError

__all__ = ["register", "import_command", "write_assembly_json", "COMMAND"]

COMMAND = "import"  # the command's name (``import`` is a Python keyword, so not the module's)


def write_assembly_json(assembly, path: Path) -> Path:
    """Write ``assembly_to_json(assembly)`` to ``path`` atomically; ``StorageError`` naming the
    path when it cannot be written (no temporary file is left)."""
    from rap.assembly import assembly_to_json
    from rap.files import committed_file_mode

    path = Path(path)
    text = json.dumps(assembly_to_json(assembly), indent=1) + "\n"
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".json", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            os.fchmod(fh.fileno(), committed_file_mode())
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise StorageError(f"{path}: cannot write: {exc.strerror or exc}; nothing was "
                           f"written") from None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    return path


def import_command(
    drawing: Path = typer.Argument(..., metavar="DRAWING", help="A .dxf or .svg drawing."),
    out: Path = typer.Option(..., "-o", "--out", help="Assembly JSON file to write."),
    units: str = typer.Option("mm", "--units", help="Output unit: mm, cm, m or in."),
    tolerance: str = typer.Option("0.01", "--tolerance",
                                  help="Chordal tolerance and coordinate grid, in the output "
                                       "unit (>= 0.000001); gaps up to it are closed."),
    parts: str = typer.Option("auto", "--parts",
                              help="auto: annotations left out, then a part per closed loop "
                                   "(loops inside loops are holes) or per face where cut lines "
                                   "are drawn once; face: faces always; loop: every path, a "
                                   "part per closed loop; layer: a part per layer (DXF layer, "
                                   "SVG top-level group)."),
    scale: Optional[float] = typer.Option(None, "--scale",
                                          help="Output units per SVG user unit (default for an "
                                               "SVG without physical units: a CSS px, 1/96 in)."),
    layers: Optional[str] = typer.Option(None, "--layers",
                                         help="Read only these layers (DXF layers, SVG "
                                              "top-level groups by id or Inkscape label), "
                                              "comma-separated."),
    skip_layers: Optional[str] = typer.Option(None, "--skip-layers",
                                              help="Leave these layers out, comma-separated."),
) -> None:
    """Import a DXF or SVG drawing of planar parts as an exact, validated assembly file."""
    from rap.cad import ImportOptions, import_drawing
    from rap.commands._flags import flags

    if out.suffix.lower() != ".json":
        raise InputError(f"--out {out}: must end in .json")
    from rap.cad.layers import parse_layer_list

    options = ImportOptions(units=units, tolerance=tolerance, parts=parts, scale=scale,
                            layers=parse_layer_list(layers),
                            skip_layers=parse_layer_list(skip_layers))
    with flags("units", "tolerance", "parts", "scale", "layers", "skip-layers"):
        result = import_drawing(drawing, options)
    write_assembly_json(result.assembly, out)
    typer.echo(f"wrote {out}: {result.summary()}")


def register(app: typer.Typer) -> None:
    app.command(COMMAND)(import_command)
