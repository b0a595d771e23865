"""Convex pieces of parts for the physics engine.

A part (outer ring with holes) is cut into convex pieces exactly by
``rap.geometry.triangulate.convex_pieces`` when that module is available. The local fallback
triangulates with shapely's constrained Delaunay triangulation (its triangles use the input vertices
only, which are mapped back to the exact input points) and merges adjacent triangles greedily while
their union stays convex, decided exactly on the ``Fraction`` coordinates (Hertel-Mehlhorn: at most
4x the minimum number of convex pieces). Fewer shapes make the simulation faster. The union of the pieces is the part exactly; conversion to
floats happens only at the end.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

from rap.assembly import Assembly, Part

__all__ = ["shrunk_piece", "convex_pieces", "triangles", "assembly_pieces", "area_centroid"]

Pt = tuple[Fraction, Fraction]


def _cross(o: Pt, a: Pt, b: Pt) -> Fraction:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _ccw(tri: tuple[Pt, ...]) -> tuple[Pt, ...]:
    return tri if _cross(*tri[:3]) > 0 else tuple(reversed(tri))


def _geometry_pieces(part: Part):
    """Convex pieces from ``rap.geometry.triangulate.convex_pieces`` (exact), or None if absent."""
    try:
        from rap.geometry.triangulate import convex_pieces as geo_pieces  # noqa: PLC0415
    except ImportError:
        return None
    den = 1
    for ring in part.rings():
        for x, y in ring:
            den = math.lcm(den, x.denominator, y.denominator)
    rings = [[(int(x * den), int(y * den)) for x, y in ring] for ring in part.rings()]
    return [[(Fraction(x, den), Fraction(y, den)) for x, y in pc]
            for pc in geo_pieces(rings[0], rings[1:])]


def _shapely_triangles(part: Part) -> list[tuple[Pt, ...]]:
    import shapely
    from shapely.geometry import Polygon

    exact: dict[tuple[float, float], Pt] = {}
    for ring in part.rings():
        for p in ring:
            exact[(float(p[0]), float(p[1]))] = p
    poly = Polygon(part.float_outer(), part.float_holes())
    tris = []
    for g in shapely.get_parts(shapely.constrained_delaunay_triangles(poly)):
        coords = list(g.exterior.coords)[:3]
        tris.append(tuple(exact.get((x, y), (Fraction(x), Fraction(y))) for x, y in coords))
    return tris


def triangles(part: Part) -> list[tuple[Pt, ...]]:
    """CCW triangles covering ``part`` exactly (exact coordinates; local shapely CDT)."""
    return [_ccw(t) for t in _shapely_triangles(part)]


def _is_convex(poly: list[Pt]) -> bool:
    n = len(poly)
    return all(_cross(poly[i], poly[(i + 1) % n], poly[(i + 2) % n]) >= 0 for i in range(n))


def _drop_collinear(poly: list[Pt]) -> list[Pt]:
    out = [p for i, p in enumerate(poly)
           if _cross(poly[i - 1], p, poly[(i + 1) % len(poly)]) != 0]
    return out


def _try_merge(a: list[Pt], b: list[Pt]) -> list[Pt] | None:
    """Union of two CCW convex polygons sharing an edge, if it is convex."""
    na, nb = len(a), len(b)
    for i in range(na):
        p, q = a[i], a[(i + 1) % na]
        for j in range(nb):
            if b[j] == q and b[(j + 1) % nb] == p:
                # a: ... p q ...; b walks q -> p; splice b's other vertices between p and q
                merged = a[: i + 1] + [b[(j + 2 + k) % nb] for k in range(nb - 2)] + a[i + 1:]
                merged = _drop_collinear(merged)
                return merged if _is_convex(merged) else None
    return None


def convex_pieces(part: Part) -> list[list[Pt]]:
    """Convex CCW pieces (exact) whose union is ``part``.

    ``rap.geometry.triangulate.convex_pieces`` when available; otherwise the local fallback (shapely
    CDT + greedy exact merge, O(t^3) for t triangles, t small).
    """
    geo = _geometry_pieces(part)
    if geo is not None:
        return geo
    return _fallback_pieces(part)


def _fallback_pieces(part: Part) -> list[list[Pt]]:
    pieces = [list(t) for t in triangles(part)]
    merged = True
    while merged:
        merged = False
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                m = _try_merge(pieces[i], pieces[j])
                if m is not None:
                    pieces[i] = m
                    del pieces[j]
                    merged = True
                    break
            if merged:
                break
    return pieces


@lru_cache(maxsize=64)
def _cached(assembly: Assembly) -> dict[str, tuple[tuple[tuple[float, float], ...], ...]]:
    return {p.id: tuple(tuple((float(x), float(y)) for x, y in piece) for piece in convex_pieces(p))
            for p in assembly.parts}


def assembly_pieces(assembly: Assembly) -> dict[str, tuple[tuple[tuple[float, float], ...], ...]]:
    """Float convex pieces of every part, keyed by part id (cached per assembly)."""
    return _cached(assembly)


def area_centroid(pieces) -> tuple[float, float, float]:
    """(area, centroid x, centroid y) of the union of float convex ``pieces`` (each a vertex
    list, counter-clockwise, as ``assembly_pieces`` gives them), by fan triangulation.
    O(total vertices); precondition: a positive total area."""
    a_sum = cx = cy = 0.0
    for poly in pieces:
        x0, y0 = poly[0]
        for (x1, y1), (x2, y2) in zip(poly[1:-1], poly[2:]):
            a = ((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)) / 2
            a_sum += a
            cx += a * (x0 + x1 + x2) / 3
            cy += a * (y0 + y1 + y2) / 3
    return a_sum, cx / a_sum, cy / a_sum


def shrunk_piece(poly, inset: float) -> list[tuple[float, float]]:
    """A float convex piece scaled about its vertex mean so that its farthest vertex comes
    ``inset`` nearer (at most halved): physics models shrink pieces so that parts which touch
    when assembled are not pressed together (the arm's pybullet world, the arm's planar twin).
    O(vertices)."""
    cx = sum(x for x, _ in poly) / len(poly)
    cy = sum(y for _, y in poly) / len(poly)
    size = max(max(abs(x - cx), abs(y - cy)) for x, y in poly) or 1.0
    f = max(0.5, 1.0 - inset / size)
    return [(cx + f * (x - cx), cy + f * (y - cy)) for x, y in poly]
