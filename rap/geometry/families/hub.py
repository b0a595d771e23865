"""A keyed hub inside rings of segments (``hub``), like the reference hexagon's hub.

A convex hub polygon (a square, a hexagon or an octagon with small integer edge directions)
is surrounded by ``rings`` rings of trapezoid segments cut along the rays from the centre through
its vertices. ``keys`` of the hub's edges (and as many of each ring's outer edges) carry a key: a
rectangular tab or a V tooth, protruding outward (a tab on the inner part) or inward (a key on the
segment), with a clearance drawn in 0..``max_clearance``. Keys are laid out in the edge's integer
frame (``rap.geometry.families.base.edge_points``), so slanted edges keep integer vertices.

Not interlocked by construction: segment k lies in the cone spanned by the rays through the
polygon's vertices k and k + 1, and the outward normal of its inner edge lies inside that cone
(the hub polygons are chosen so), so the outermost segment leaves along that normal without
touching its neighbours (a cone is closed under addition) and its keys slide out along their axes;
the rings come off outside in, the hub last. Parts: 1 + sides x rings. Cost: O(parts).
"""

from __future__ import annotations

import math

import numpy as np

from rap.geometry.families.base import Family, Option, make_part, shared_edge

__all__ = ["HUB"]

# unit polygons (counter-clockwise) whose edges have small primitive directions
_POLYGONS = {
    "4": [(1, -1), (1, 1), (-1, 1), (-1, -1)],
    "6": [(2, 0), (1, 2), (-1, 2), (-2, 0), (-1, -2), (1, -2)],
    "8": [(3, -1), (3, 1), (1, 3), (-1, 3), (-3, 1), (-3, -1), (-1, -3), (1, -3)],
}
_EXTENT = 44  # largest coordinate of the outer ring


def _count(o: dict) -> int:
    return 1 + int(o["sides"]) * o["rings"]


def _edge_frame(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    g = math.gcd(dx, dy)
    return g, math.hypot(dx // g, dy // g)  # length in units of e, and |e|


def _distance_to_line(a, b, points) -> float:
    """Smallest distance from the line through a and b to the given points."""
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    return min(abs((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])) / length
               for p in points)


def _hub(rng: np.random.Generator, o: dict) -> list:
    unit = _POLYGONS[o["sides"]]
    n, rings = len(unit), o["rings"]
    top = max(max(abs(x), abs(y)) for x, y in unit)
    s_out = _EXTENT // top
    s_in = max(3, int(round(s_out * rng.uniform(0.36, 0.46))))
    scales = [s_in] + [s_in + (s_out - s_in) * (r + 1) // rings for r in range(rings)]
    polys = [[(x * s, y * s) for x, y in unit] for s in scales]
    # keyed edges: the same count on every boundary between a part and the ring around it
    edges = {}  # (boundary r, edge k) -> (left polyline a -> b, right polyline b -> a)
    for r in range(rings):
        poly, nxt = polys[r], polys[r + 1]
        keyed = set(rng.choice(n, size=min(o["keys"], n), replace=False).tolist())
        for k in range(n):
            a, b = poly[k], poly[(k + 1) % n]
            if k not in keyed:
                edges[r, k] = shared_edge(a, b, None)
                continue
            g, e_len = _edge_frame(a, b)
            # room: a third of the thickness of the part the key enters (the hub's apothem or a
            # ring's thickness along this edge's normal), and a quarter of the edge
            side = 1 if rng.random() < 0.5 else -1  # 1: key on the outer part, into the inner one
            inner = polys[r - 1] if r else [(0, 0)] * n
            into = (inner[k], inner[(k + 1) % n]) if side == 1 else (nxt[k], nxt[(k + 1) % n])
            room = _distance_to_line(a, b, into) / 3
            c_len = int(rng.integers(0, o["max_clearance"] + 1))
            c = 0 if c_len == 0 else max(1, int(round(c_len / e_len)))
            if int(room / e_len) - c < 1 or g // 4 - c < 1:
                c = 0  # no room for a clearance here
            if int(room / e_len) < 1 or g // 4 < 1:
                edges[r, k] = shared_edge(a, b, None)
                continue
            depth = max(1, min(int(round(rng.uniform(3, 7) / e_len)), int(room / e_len) - c))
            half = max(1, min(int(round(rng.uniform(2, 5) / e_len)), g // 4 - c))
            profile = [(half, 0), (half, depth)] if rng.random() < 0.6 else [(half, 0), (0, depth)]
            edges[r, k] = shared_edge(a, b, profile, g // 2, side=side, clearance=c)
    parts = [make_part("hub", [p for k in range(n) for p in edges[0, k][0]])]
    for r in range(rings):
        inner, outer = polys[r], polys[r + 1]
        for k in range(n):
            k1 = (k + 1) % n
            pts = [inner[k], outer[k]]
            pts += edges[r + 1, k][0] if r + 1 < rings else [outer[k], outer[k1]]
            pts += [inner[k1], *edges[r, k][1]]
            parts.append(make_part(f"s{r}_{k}" if rings > 1 else f"s{k}", pts))
    return parts


HUB = Family(
    "hub", "A keyed hub (square, hexagon or octagon) in rings of segments with tabs and V keys.",
    (Option("sides", "Sides of the hub polygon.", choices=("4", "6", "8")),
     Option("rings", "Rings of segments around the hub.", 1, 3, draw_low=1, draw_high=2),
     Option("keys", "Keyed edges per ring boundary (the others are flat).", 0, 8,
            draw_low=1, draw_high=3),
     Option("max_clearance", "Each key's clearance is drawn in 0..this (length units).", 0, 4,
            draw_low=0, draw_high=2)),
    _hub, _count, ("sides", "rings"))
