"""Arches and vaults: voussoirs and a keystone on two piers, over a base (``arch``).

A semicircular arch of ``2 pairs + 1`` voussoirs (the middle one the keystone, ``key``) springs
from two rectangular piers standing on a base slab. Joint ``i`` of the arch runs radially from the
intrados (radius ``r``) to the extrados (``R = r + thickness``) at the parameter
``t_i = i / (v - i)`` of the circle's rational parametrisation ``((1 - t^2), 2t) / (1 + t^2)``
(``v`` voussoirs): angles 0 and 180 degrees at the springings, 90 at the crown, symmetric. Every
joint point is computed as a ``Fraction`` and rounded to the integer grid once, and both voussoirs
of a joint use the same two points, so neighbours share their joint exactly. ``kind`` ``vault``
adds the haunches' fill: one spandrel block a side, standing on the widened pier and lying on the
extrados up to a level above the crown, with an open slot above the keystone.

Not interlocked: the keystone leaves upward (its joints open upward), then the spandrels (nothing
above them), the voussoirs outward, the piers upward, the base last; ``verify`` checks it exactly.
Parts: 3 + 2 pairs + 1 (arch: 6, 8, 10 for pairs 1-3) and 2 more for a vault. Cost: O(parts).
Held out of training (``Family.training`` False): a shape kind no training family resembles.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["ARCH"]


def _count(o: dict) -> int:
    return 3 + 2 * o["pairs"] + 1 + (2 if o["kind"] == "vault" else 0)


def _on_circle(cx: int, cy: int, radius: int, i: int, v: int) -> tuple[int, int]:
    """The integer point nearest to the circle point of joint ``i`` of ``v`` (exact rounding)."""
    a, b = v - i, i  # t = b / a; (1 - t^2, 2t) / (1 + t^2) = (a^2 - b^2, 2ab) / (a^2 + b^2)
    d = a * a + b * b
    return (cx + round(Fraction(radius * (a * a - b * b), d)),
            cy + round(Fraction(radius * 2 * a * b, d)))


def _arch(rng: np.random.Generator, o: dict) -> list:
    v = 2 * o["pairs"] + 1
    r = int(rng.integers(4 * v // 3 + 8, 4 * v // 3 + 15))
    thick = int(rng.integers(5, 10))
    big = r + thick
    pier_h = int(rng.integers(8, 17))
    pier_out = int(rng.integers(0, 5)) + (6 if o["kind"] == "vault" else 0)  # beyond the extrados
    margin = int(rng.integers(3, 8))
    base_h = int(rng.integers(4, 8))
    cx, cy = 0, pier_h
    inner = [_on_circle(cx, cy, r, i, v) for i in range(v + 1)]
    outer = [_on_circle(cx, cy, big, i, v) for i in range(v + 1)]
    left, right = -big - pier_out, big + pier_out
    parts = [make_part("base", [(left - margin, -base_h), (right + margin, -base_h),
                                (right + margin, 0), (left - margin, 0)]),
             make_part("pierR", [(r, 0), (right, 0), (right, pier_h), (r, pier_h)]),
             make_part("pierL", [(left, 0), (-r, 0), (-r, pier_h), (left, pier_h)])]
    key = v // 2
    for k in range(v):
        pid = "key" if k == key else f"v{k}"
        parts.append(make_part(pid, [inner[k], outer[k], outer[k + 1], inner[k + 1]]))
    if o["kind"] == "vault":
        top = cy + big + int(rng.integers(3, 7))
        # right spandrel: on the pier beyond the extrados, along the extrados up to the keystone
        ring_r = [(big, cy), (right, cy), (right, top), (outer[key][0], top)]
        ring_r += [outer[i] for i in range(key, 0, -1)]
        ring_l = [(-big, cy)] + [outer[i] for i in range(v - 1, key, -1)]
        ring_l += [(outer[key + 1][0], top), (left, top), (left, cy)]
        parts += [make_part("spanR", ring_r), make_part("spanL", ring_l)]
    return parts


ARCH = Family(
    "arch", "A semicircular arch of voussoirs and a keystone on two piers over a base (vault: with "
    "its haunches filled).",
    (Option("pairs", "Voussoirs on each side of the keystone.", 1, 6, draw_low=1, draw_high=3),
     Option("kind", "arch: the ring alone; vault: with a spandrel block on each haunch.",
            choices=("arch", "vault"))),
    _arch, _count, ("pairs", "kind"), training=False)
