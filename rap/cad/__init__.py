"""CAD import: DXF and SVG drawings of planar parts to exact, validated assemblies.

``import_drawing(path, ImportOptions(units="mm", tolerance="0.01", parts="auto", scale=None,
layers=None, skip_layers=None))`` returns an ``ImportResult`` whose ``assembly`` is validated
exactly; ``rap.io.load_assembly``
calls it with the default options for a ``.dxf`` or ``.svg`` path, so every command that takes an
assembly takes a drawing. Modules, one family each: ``dxf`` and ``svg`` (readers: entities to
float paths in the output unit), ``loops`` (joining paths into closed loops), ``edges`` (shared
boundaries: ends merged into nodes, one geometry per edge, T-junctions split), ``rings`` (exact
rings on the grid, shared boundaries given the same vertices, checked simple), ``parts`` (holes by
containment, parts per loop or per layer), ``snap`` (the tolerance grid), ``layers`` (``--layers``,
``--skip-layers``), ``importer`` (the pipeline and validation); the room ``arrangement`` holds
what loops alone do not explain: ``annotations`` (what is not a part's outline: construction and
dimension lines, symbols, frames, outlines drawn again), ``faces`` (parts as the faces of cut
lines drawn once, noded with snap rounding), ``overlay`` (hand-placed loops overlapping by less
than the tolerance).

Layer: above ``rap.assembly`` and ``rap.geometry``, beside ``rap.io`` (which imports it lazily);
no ray, torch or rendering. ezdxf and svgelements are imported inside the readers.
"""

from rap.cad.drawing import DrawingError
from rap.cad.importer import DRAWING_SUFFIXES, ImportOptions, ImportResult, import_drawing

__all__ = ["import_drawing", "ImportOptions", "ImportResult", "DrawingError", "DRAWING_SUFFIXES"]
