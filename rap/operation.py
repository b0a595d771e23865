"""Assembly operations: two subassemblies merged by a one-step translation.

``Operation.direction`` is the unit vector along which the *moving* subassembly travels to its
place (the reverse of the disassembly motion found in the NDBG). ``exact_direction`` keeps the
rational vector the float unit vector was derived from, when there is one; ``direction_index``
tells the middle of a direction range (0) from seeded directions inside it (1, 2, ...).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from fractions import Fraction

__all__ = ["Operation", "unit", "subset_key"]


def unit(dx: float, dy: float) -> tuple[float, float]:
    """Float unit vector of (dx, dy); precondition: not the zero vector."""
    n = math.hypot(dx, dy)
    return (dx / n, dy / n)


def subset_key(ids) -> str:
    """Canonical text of a set of part ids: sorted, comma-joined."""
    return ",".join(sorted(ids))


@dataclass(frozen=True)
class Operation:
    """Merge ``moving`` into ``fixed`` by translating ``moving`` along ``direction`` to its place."""

    moving: frozenset[str]
    fixed: frozenset[str]
    direction: tuple[float, float]
    exact_direction: tuple[Fraction, Fraction] | None = None
    # which of its partition's directions this is: 0 the middle of the merged range, 1.. seeded
    # directions inside it (``rap.enumerate.partition_operations``); not part of the content
    direction_index: int = field(default=0, compare=False)

    def __post_init__(self):
        if not self.moving or not self.fixed or self.moving & self.fixed:
            raise ValueError("moving and fixed must be non-empty and disjoint")

    @property
    def subassembly(self) -> frozenset[str]:
        return self.moving | self.fixed

    def key(self, geometry_hash: str, params_fingerprint: str = "") -> str:
        """Content key (hex SHA-256) of geometry + operation (+ simulator parameters).

        Depends only on content: the same operation gets the same key in every process.
        """
        dx, dy = self.direction
        text = "|".join([geometry_hash, subset_key(self.moving), subset_key(self.fixed),
                         f"{dx!r},{dy!r}", params_fingerprint])
        return hashlib.sha256(text.encode()).hexdigest()

    def describe(self) -> str:
        dx, dy = self.direction
        return f"{{{subset_key(self.moving)}}} -> {{{subset_key(self.fixed)}}} along ({dx:+.3f}, {dy:+.3f})"
