"""Parametric assembly families: seeded generators of valid, non-interlocked assemblies.

``FAMILIES`` maps a family name to its ``Family`` (``rap.geometry.families.base``): a one-line
description, its options (range, default; a default of None is drawn per seed) and a builder.
``generate(family, seed, **options)`` returns the assembly drawn with ``family_rng(family, seed)``,
named ``FAMILY-sSEED`` (plus ``-OPTIONVALUE`` for each explicit option, so different options never
share a name). Every result has exact integer coordinates and is verified exactly: valid
(``validate_assembly``) and decomposable into single parts over online NDBG partitions. With the
default options a family gives 4-16 parts; options allow larger instances (e.g. ``wall`` with
``rows=4, bricks=5``: 22 bricks; ``convex`` with ``rows=5, cols=6, cell="quad"``: 30 cells).

Families (one module per group): ``pegs``, ``funnels`` (pegs.py); ``hub`` (hub.py); ``c-shapes``
(shapes.py); ``knobs`` (knobs.py); ``convex``, ``wall`` (tilings.py); ``packing``,
``polyomino`` (packings.py); ``fan`` (fans.py).

No ray, no torch, no pymunk. Deterministic: the same (family, seed, options) gives the same parts.
Cost: building is O(parts) (``packing`` and ``polyomino`` retry rejected drafts, each checked with
the NDBG); verification builds one NDBG, about O(n^2) for n parts (milliseconds at 16 parts).
"""

from __future__ import annotations

import hashlib

import numpy as np

from rap.assembly import Assembly
from rap.errors import InputError, ParameterError
from rap.geometry.families.base import DEFAULT_PARTS, Family, FamilyError, Option, verify
from rap.geometry.families.fans import FAN
from rap.geometry.families.hub import HUB
from rap.geometry.families.knobs import KNOBS
from rap.geometry.families.packings import PACKING, POLYOMINO
from rap.geometry.families.pegs import FUNNELS, PEGS
from rap.geometry.families.shapes import C_SHAPES
from rap.geometry.families.tilings import CONVEX, WALL

__all__ = ["FAMILIES", "Family", "Option", "FamilyError", "DEFAULT_PARTS", "generate", "family_rng",
           "get_family", "assembly_name", "family_table", "verify"]

FAMILIES: dict[str, Family] = {f.name: f for f in (
    PEGS, FUNNELS, HUB, C_SHAPES, KNOBS, CONVEX, WALL, PACKING, POLYOMINO, FAN)}


def get_family(name: str) -> Family:
    """The family called ``name``; ``InputError`` listing the families otherwise."""
    try:
        return FAMILIES[name]
    except KeyError:
        raise InputError(f"no assembly family {name!r}; choose one of {', '.join(FAMILIES)}") from None


def assembly_name(family: str, seed: int, **options) -> str:
    """``FAMILY-sSEED`` followed by ``-NAMEVALUE`` per explicit option, in the family's order."""
    fam = get_family(family)
    extra = "".join(f"-{o.name.replace('_', '')}{options[o.name]}" for o in fam.options
                    if options.get(o.name) is not None)
    return f"{family}-s{seed}{extra}"


def generate(family: str, seed: int, **options) -> Assembly:
    """The verified assembly of ``family`` for ``seed`` (``family_rng(family, seed)``).

    Unknown families or options raise ``InputError``; a bad ``seed`` or option value
    ``ParameterError`` naming it (``rows 0: must be between 1 and 20``).
    """
    fam = get_family(family)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError("seed", seed, "must be a non-negative integer")
    return fam.make(family_rng(family, int(seed)), name=assembly_name(family, int(seed), **options),
                    **options)


def family_rng(family: str, seed: int) -> np.random.Generator:
    """The generator of ``family``'s assembly for ``seed``: ``SeedSequence([seed, family tag])``,
    so that neighbouring seeds and different families draw unrelated streams."""
    tag = int.from_bytes(hashlib.sha256(family.encode()).digest()[:4], "little")
    return np.random.default_rng(np.random.SeedSequence([int(seed), tag]))


def family_table() -> list[tuple[str, str, str, str]]:
    """(name, description, parts with the default options, options) for every family."""
    rows = []
    for f in FAMILIES.values():
        lo, hi = f.part_range()
        rows.append((f.name, f.description, f"{lo}-{hi}",
                     ", ".join(o.describe() for o in f.options)))
    return rows
