"""Dovetailed courses: tails locked in sockets that two lower blocks form together (``dovetail``).

A base slab carries a course of ``blocks`` blocks; between neighbours k and k + 1 of that course
runs a dovetail socket through the course's whole height, narrow at the top (half-width ``m``)
and flared at the bottom (by ``f_left`` and ``f_right`` on its two sides, each drawn in 0..``flare``
with at least one positive: a full dovetail or a half one). Over each socket stands an upper
block whose tail fills it exactly; neighbouring upper blocks touch along vertical joints, the end
ones overhang the course's ends. Neither block of a socket can leave upward while the tail is in
it, and the tail cannot leave upward between them: the assembly comes apart sideways from an end
(the end block of the lower course slides out along the base, then its tail's block leaves up and
out, and so on), an order the flares force.

Exact integers. Not interlocked (the order above; ``verify`` checks it exactly). Parts:
1 + blocks + (blocks - 1) (6, 8, 10, 12 for 3-6 blocks). Cost: O(parts).
Held out of training (``Family.training`` False).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["DOVETAIL"]


def _count(o: dict) -> int:
    return 2 * o["blocks"]


def _dovetail(rng: np.random.Generator, o: dict) -> list:
    n, fmax = o["blocks"], o["flare"]
    h1 = int(rng.integers(8, 15))
    h2 = int(rng.integers(6, 12))
    base_h = int(rng.integers(4, 8))
    joints = []  # (centre x, mouth half-width, flare left, flare right)
    x = 0  # the foot of the previous socket's right side (the course's left end at first)
    for _ in range(n - 1):
        m = int(rng.integers(2, 5))
        fl, fr = (int(v) for v in rng.integers(0, fmax + 1, size=2))
        if fl == 0 and fr == 0:
            fl = fr = 1 + int(rng.integers(0, fmax))
        c = x + int(rng.integers(4, 10)) + fl + m  # a lower block's foot: 4-9 units wide
        joints.append((c, m, fl, fr))
        x = c + m + fr
    right = x + int(rng.integers(4, 10))
    left = 0
    parts = [make_part("base", [(left - 4, -base_h), (right + 4, -base_h), (right + 4, 0),
                                (left - 4, 0)])]
    # lower course: block k between socket k - 1 (its left side) and socket k (its right side)
    for k in range(n):
        ring = []
        if k == 0:
            ring += [(left, h1), (left, 0)]
        else:
            c, m, fl, fr = joints[k - 1]
            ring += [(c + m, h1), (c + m + fr, 0)]
        if k == n - 1:
            ring += [(right, 0), (right, h1)]
        else:
            c, m, fl, fr = joints[k]
            ring += [(c - m - fl, 0), (c - m, h1)]
        parts.append(make_part(f"l{k}", ring))
    # upper course: block j over socket j, cut halfway between neighbouring sockets
    cuts = [left - int(rng.integers(0, 4))]
    for j in range(n - 2):
        a, b = joints[j], joints[j + 1]
        cuts.append((a[0] + b[0]) // 2)
    cuts.append(right + int(rng.integers(0, 4)))
    for j, (c, m, fl, fr) in enumerate(joints):
        x0, x1 = cuts[j], cuts[j + 1]
        parts.append(make_part(f"u{j}", [(c - m - fl, 0), (c + m + fr, 0), (c + m, h1), (x1, h1),
                                         (x1, h1 + h2), (x0, h1 + h2), (x0, h1), (c - m, h1)]))
    return parts


DOVETAIL = Family(
    "dovetail", "Two courses over a base: each upper block's dovetail tail fills a socket that two "
    "lower blocks form together.",
    (Option("blocks", "Blocks of the lower course (the upper one has one fewer).", 2, 12,
            draw_low=3, draw_high=6),
     Option("flare", "Largest flare of a socket side at its foot.", 1, 6, draw_low=1, draw_high=4)),
    _dovetail, _count, ("blocks",), training=False)
