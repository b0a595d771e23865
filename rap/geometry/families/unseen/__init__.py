"""Held-out shape kinds: families generated like the others and never used for training.

``UNSEEN`` maps a name to its ``Family`` (``Family.training`` False): ``arch`` (arches and vaults:
voussoirs and a keystone on piers over a base; arches.py), ``dovetail`` (tails in sockets formed
by two blocks; dovetails.py), ``puzzle`` (jigsaw pieces with curved tabs as integer polylines;
puzzles.py), ``bond`` (English and Flemish bonds with studded, interlocking courses; bonds.py).
``rap.geometry.families`` lists them in ``ALL_FAMILIES`` (what ``generate`` and ``rap-farm
generate`` accept) and ``HELD_OUT``, never in ``FAMILIES`` (what the corpus is labelled from);
training leaves ``HELD_OUT`` out of every selection (``rap.model.training.trainset``). They are the
shape kinds of the leave-one-family-out evaluation (research/leave_one_family_out.py).

Exact integer geometry, seeded by the caller's generator, verified like every family. Default
sizes 6-12 parts. No ray, no torch. Cost: O(parts) each, plus the verification's NDBG.
"""

from __future__ import annotations

from rap.geometry.families.base import Family
from rap.geometry.families.unseen.arches import ARCH
from rap.geometry.families.unseen.bonds import BOND
from rap.geometry.families.unseen.dovetails import DOVETAIL
from rap.geometry.families.unseen.puzzles import PUZZLE

__all__ = ["UNSEEN"]

UNSEEN: dict[str, Family] = {f.name: f for f in (ARCH, DOVETAIL, PUZZLE, BOND)}
