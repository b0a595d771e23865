"""Fans of triangles around a common apex (``fan``).

``triangles`` triangles share the apex O = (0, 0); their outer vertices lie at drawn radii around
``radius`` (+- ``jitter``) and at angles spread evenly (+- a third of a step) over the ``layout``:

* ``pie``: the full turn (a star-shaped polygon cut into wedges); parts: triangles;
* ``half``: a half turn standing on a flat base plate; parts: triangles + 1;
* ``corner``: a quarter turn in an L-shaped holder (a floor and a wall meeting at O); parts:
  triangles + 1.

Outer vertices are rounded to integers; a draw in which a triangle is not strictly
counter-clockwise is redrawn (at most 100 times, then without jitter).

Not interlocked by construction: triangle k lies in the cone spanned by its two outer vertices
(apex O), and translating it along a direction inside that cone keeps it inside the cone (a cone
is closed under addition) and moves it away from the base or holder, which lie outside the
spread; so every triangle leaves alone, the base last. Cost: O(parts).
"""

from __future__ import annotations

import math

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["FAN"]

_SPREAD = {"pie": 2 * math.pi, "half": math.pi, "corner": math.pi / 2}


def _count(o: dict) -> int:
    return o["triangles"] + (0 if o["layout"] == "pie" else 1)


def _outer(rng: np.random.Generator, n: int, layout: str, radius: int, jitter: int) -> list:
    spread = _SPREAD[layout]
    closed = layout == "pie"
    m = n if closed else n + 1  # outer vertices
    step = spread / n
    angles = [k * step + (0.0 if (not closed and k in (0, n)) else rng.uniform(-step / 3, step / 3))
              for k in range(m)]
    radii = [radius + int(rng.integers(-jitter, jitter + 1)) for _ in range(m)]
    pts = [(int(round(r * math.cos(a))), int(round(r * math.sin(a)))) for r, a in zip(radii, angles)]
    if not closed:  # the first and last rays lie exactly on the base (or the holder)
        pts[0] = (radii[0], 0)
        pts[-1] = (-radii[-1], 0) if layout == "half" else (0, radii[-1])
    return pts


def _ccw(a, b) -> bool:
    return a[0] * b[1] - a[1] * b[0] > 0


def _fan(rng: np.random.Generator, o: dict) -> list:
    n, layout, radius = o["triangles"], o["layout"], o["radius"]
    closed = layout == "pie"
    for attempt in range(101):
        pts = _outer(rng, n, layout, radius, o["jitter"] if attempt < 100 else 0)
        if all(_ccw(pts[k], pts[(k + 1) % len(pts)]) for k in range(n)):
            break
    parts = [make_part(f"t{k}", [(0, 0), pts[k], pts[(k + 1) % len(pts)]]) for k in range(n)]
    if closed:
        return parts
    t = int(rng.integers(5, 10))
    reach = max(x for x, _ in pts) + int(rng.integers(2, 8))
    if layout == "half":
        left = min(x for x, _ in pts) - int(rng.integers(2, 8))
        base = [(left, -t), (reach, -t), (reach, 0), (left, 0)]
    else:
        top = max(y for _, y in pts) + int(rng.integers(2, 8))
        base = [(-t, -t), (reach, -t), (reach, 0), (0, 0), (0, top), (-t, top)]
    return [make_part("base", base), *parts]


FAN = Family(
    "fan", "Triangles fanned around one apex: a full pie, a half fan on a base, a corner fan.",
    (Option("triangles", "Triangles in the fan.", 2, 24, draw_low=4, draw_high=10),
     Option("layout", "Spread of the fan.", choices=tuple(_SPREAD)),
     Option("radius", "Radius of the outer vertices.", 10, 150, draw_low=30, draw_high=50),
     Option("jitter", "Largest change of an outer vertex's radius.", 0, 20, draw_low=0,
            draw_high=6)),
    _fan, _count, ("triangles", "layout"),
    lambda o: (("triangles", "a pie needs at least 3")
               if o["layout"] == "pie" and o["triangles"] < 3 else None))
