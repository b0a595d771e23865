"""Choosing a drawing's layers: ``--layers A,B`` and ``--skip-layers C``.

A layer is a DXF layer, or an SVG top-level group (an Inkscape layer or any other group at the top
of the document), named by its id or its Inkscape label. ``choose_layers(drawing, layers, skip)``
keeps the paths on the layers named by ``layers`` (all when None) and not on those named by
``skip``; an SVG element outside any group is on no layer and is kept unless ``layers`` is given.
A name that is no layer of the drawing is a ``ParameterError`` (exit status 2) that lists the
layers there are. Counts of entities left out that way go into the drawing's ``ignored``. No
third-party imports; linear in the paths.
"""

from __future__ import annotations

from collections import Counter

from rap.cad.drawing import Drawing, DrawnPath
from rap.errors import ParameterError

__all__ = ["choose_layers", "layer_names", "parse_layer_list"]


def parse_layer_list(text: str | None) -> tuple[str, ...] | None:
    """``"A,B"`` as ``("A", "B")``; None or empty as None."""
    if text is None:
        return None
    names = tuple(n.strip() for n in str(text).split(",") if n.strip())
    return names or None


def layer_names(drawing: Drawing) -> dict[str, set[str]]:
    """Each layer of the drawing's paths and entities with the names it answers to."""
    names: dict[str, set[str]] = {}
    for p in drawing.paths:
        if p.source.layer is not None:
            names.setdefault(p.source.layer, set()).update(
                drawing.layer_names.get(p.source.layer, {p.source.layer}))
    for key in drawing.ignored:
        layer = key[1] if isinstance(key, tuple) else None
        if layer is not None:
            names.setdefault(layer, set()).update(drawing.layer_names.get(layer, {layer}))
    return names


def _resolve(option: str, wanted: tuple[str, ...], names: dict[str, set[str]]) -> set[str]:
    out = set()
    for w in wanted:
        hits = {layer for layer, aliases in names.items() if w in aliases}
        if not hits:
            there = ", ".join(sorted(names)) or "none: every path is outside a layer"
            raise ParameterError(option, w, f"no such layer in the drawing (layers: {there})")
        out |= hits
    return out


def choose_layers(drawing: Drawing, layers: tuple[str, ...] | None,
                  skip: tuple[str, ...] | None) -> list[DrawnPath]:
    """The paths on the chosen layers (see the module doc)."""
    if not layers and not skip:
        return list(drawing.paths)
    names = layer_names(drawing)
    keep = _resolve("layers", layers, names) if layers else None
    drop = _resolve("skip-layers", skip, names) if skip else set()
    out: list[DrawnPath] = []
    skipped: Counter = Counter()
    for p in drawing.paths:
        layer = p.source.layer
        if (keep is not None and layer not in keep) or layer in drop:
            skipped[layer] += 1
        else:
            out.append(p)
    for layer, n in skipped.items():
        drawing.ignored[("path not chosen", layer)] += n
    return out
