"""Pegged stacks: blocks whose pegs sit in slots of the layer below (``pegs``, ``funnels``).

A base plate carries ``layers`` rows of ``blocks`` rectangular blocks in aligned columns, ``gap``
apart (0: neighbours touch). Every block has one peg under it, in a slot of the block (or plate)
below it; the slot is the peg's socket with the peg's own clearance (``rap.geometry.families.base``).

* ``pegs``: rectangular pegs; each peg's clearance is drawn in 0..``max_clearance`` (0: a tight
  peg-in-hole that admits one direction; 1-3 units: a loose one).
* ``funnels``: pegs with chamfered tips in slots with chamfered mouths (``chamfer``), V teeth in
  V grooves, or trapezoid teeth (``shape``; ``mixed`` draws one per peg): insertions that guide the
  peg home, of a size drawn per assembly.

Not interlocked by construction: the top block of a column leaves upward (its neighbours touch it
along vertical sides only), so the stack comes apart top down, the plate last. Parts: 1 + blocks x
layers. Block and plate sizes follow the pegs, so every option combination fits. Cost: O(parts).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, edge_points, make_part

__all__ = ["PEGS", "FUNNELS"]

_COMMON = (
    Option("blocks", "Blocks per layer.", 1, 12, draw_low=2, draw_high=5),
    Option("layers", "Layers of blocks on the plate.", 1, 6, draw_low=1, draw_high=3),
    Option("gap", "Space between neighbouring blocks of a layer (0: they touch).", 0, 8,
           draw_low=0, draw_high=4),
    Option("peg_half", "Half-width of a peg.", 1, 8, draw_low=2, draw_high=4),
    Option("depth", "Depth of a peg (and its slot).", 1, 12, draw_low=3, draw_high=6),
)


def _count(o: dict) -> int:
    return 1 + o["blocks"] * o["layers"]


def _stack(rng: np.random.Generator, o: dict, pegs: list, widest: int) -> list:
    """Parts of a stack; ``pegs[l][k] = (knob_half, socket_half)`` for block k of layer l;
    ``widest``: the largest half-width of a socket at its mouth."""
    n, layers, gap = o["blocks"], o["layers"], o["gap"]
    deepest = max(max(v for _, v in sock) for row in pegs for _, sock in row)
    margin = int(rng.integers(3, 6))
    bw = 2 * (widest + margin)
    bh = deepest + int(rng.integers(4, 8))
    plate_h = deepest + int(rng.integers(3, 6))
    edge = int(rng.integers(2, 7))
    width = 2 * edge + n * bw + (n - 1) * gap
    shift = [[int(rng.integers(-(margin - 2), margin - 1)) for _ in range(n)] for _ in range(layers)]
    xs = [edge + k * (bw + gap) for k in range(n)]

    def bottom(l, k):  # (the block's bottom a -> b, the top of the part below b -> a)
        a, b = (xs[k], l * bh), (xs[k] + bw, l * bh)
        knob, sock = pegs[l][k]
        at = bw // 2 + shift[l][k]
        return edge_points(a, b, knob, at, side=-1), edge_points(a, b, sock, at, side=-1)[::-1]

    parts = []
    plate_top = []
    for k in reversed(range(n)):
        plate_top += bottom(0, k)[1]
    parts.append(make_part("base", [(0, -plate_h), (width, -plate_h), (width, 0), *plate_top, (0, 0)]))
    for l in range(layers):
        for k in range(n):
            x0, x1, y0, y1 = xs[k], xs[k] + bw, l * bh, (l + 1) * bh
            top = bottom(l + 1, k)[1] if l + 1 < layers else [(x1, y1), (x0, y1)]
            parts.append(make_part(f"b{l}_{k}", [*bottom(l, k)[0], *top]))
    return parts


def _pegs(rng: np.random.Generator, o: dict) -> list:
    u, d, cmax = o["peg_half"], o["depth"], o["max_clearance"]
    rect = [(u, 0), (u, d)]
    pegs = []
    for _ in range(o["layers"]):
        row = []
        for _ in range(o["blocks"]):
            c = int(rng.integers(0, cmax + 1))
            row.append((rect, [(u + c, 0), (u + c, d + c)]))
        pegs.append(row)
    return _stack(rng, o, pegs, u + cmax)


def _funnels(rng: np.random.Generator, o: dict) -> list:
    u, d, cmax, ch, tip = o["peg_half"], o["depth"], o["max_clearance"], o["chamfer"], o["tip"]
    tip = min(tip, u, d - 1)
    pegs = []
    widest = u + cmax
    for _ in range(o["layers"]):
        row = []
        for _ in range(o["blocks"]):
            shape = o["shape"] if o["shape"] != "mixed" else ("chamfer", "v", "trapezoid")[
                int(rng.integers(3))]
            c = int(rng.integers(0, cmax + 1))
            if shape == "chamfer":  # chamfered tip in a slot with a chamfered mouth
                knob = [(u, 0), (u, d - tip), (u - tip, d)] if tip else [(u, 0), (u, d)]
                m = min(ch, d + c - 1)
                sock = [(u + c + m, 0), (u + c, m), (u + c, d + c)]
                widest = max(widest, u + c + m)
            elif shape == "v":  # a V tooth in a V groove
                knob = [(u + ch, 0), (0, d)]
                sock = [(u + ch + c, 0), (0, d + c)]
                widest = max(widest, u + ch + c)
            else:  # a trapezoid tooth narrowing by ``chamfer`` on each side
                k = min(ch, u)
                knob = [(u + k, 0), (u, d)]
                sock = [(u + k + c, 0), (u + c, d + c)]
                widest = max(widest, u + k + c)
            row.append((knob, sock))
        pegs.append(row)
    return _stack(rng, o, pegs, widest)


PEGS = Family(
    "pegs", "Stacked blocks with rectangular pegs in slots, tight (clearance 0) or loose.",
    _COMMON + (Option("max_clearance", "Each peg's clearance is drawn in 0..this.", 0, 4,
                      draw_low=1, draw_high=3),),
    _pegs, _count, ("blocks", "layers"))

FUNNELS = Family(
    "funnels", "Stacked blocks with chamfered pegs, V teeth or trapezoid teeth: guided insertions.",
    _COMMON + (
        Option("shape", "Peg shape (mixed: drawn per peg).", choices=("chamfer", "v", "trapezoid",
                                                                       "mixed")),
        Option("chamfer", "Chamfer of a slot's mouth / widening of a tooth.", 1, 8,
               draw_low=1, draw_high=4),
        Option("tip", "Chamfer of a peg's tip (chamfer shape).", 0, 6, draw_low=0, draw_high=2),
        Option("max_clearance", "Each peg's clearance is drawn in 0..this.", 0, 4,
               draw_low=0, draw_high=1),
    ),
    _funnels, _count, ("blocks", "layers"))
