"""Simplified shapes for the simulator: a part of many convex pieces seen through a few, within a
tolerance of it. The exact polygon stays everywhere else (the NDBG, the plan, its poses).

Why: a part's exact convex decomposition (``rap.sim.shapes.convex_pieces``) has about one piece
per reflex vertex, and a curved part from a drawing has many: a gear of 300-1,300 vertices, with
teeth and holes, gives 50-170 pieces, copied for every trial. A step's cost grows faster than the
moving body's piece count (most likely Chipmunk's broad phase, which pairs one body's shapes whose
boxes meet before dropping them as the same body's): the orrery's 114-piece gear took 15.5 s for
20 trials where a 53-piece version of it took 1.2 s, and a plan's 8 simulations of two meshing
120-piece gears 465 s against 41 s at 32 pieces (docs/RESULTS.md, "Curved parts").

``outline(part, tolerance, max_pieces)``: the part's ``Outline``, float convex pieces. A part of at
most ``max_pieces`` exact pieces is kept exact, piece for piece. Otherwise, greedily, the two
pieces whose convex hull adds the least area to them are replaced by that hull, as long as the hull
lies within ``tolerance`` of the part (inside the part grown by the tolerance; shapely's round
buffer is inscribed in the true offset, so the test is conservative): a tooth's pieces become one,
the slivers around a hole become a few chords across it. When no such merge is left and more than
``max_pieces`` pieces remain, the tolerance doubles and the merging goes on (``Outline.tolerance``
says where it ended).

Guarantees: the union of the pieces contains the part (pieces only grow) and lies within the
tolerance used of it (so the Hausdorff distance between them is at most that); at most
``max(1, max_pieces)`` pieces, each convex, counter-clockwise, of positive area. Pieces of one
part may overlap where a hull reaches over a neighbour: the body's mass counts the overlap twice
(up to 8% of a gear's area on the gear sheets), which moves its centroid and moment a little, not
the shapes that collide. Floats (physics), deterministic. Cost: O(p^2) box tests and O(p k)
shapely hulls for p exact pieces and k neighbours each, once per part (0.1-0.4 s for a gear of
50-170 pieces); ``assembly_outlines`` memoises per assembly and parameters, and parts of at most
``max_pieces`` pieces cost nothing.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from functools import lru_cache

from rap.assembly import Assembly, Part

__all__ = ["Outline", "outline", "part_tolerance", "assembly_outlines"]

FPt = tuple[float, float]


@dataclass(frozen=True)
class Outline:
    """A part as the simulator sees it: convex CCW float ``pieces``, and the ``tolerance`` they
    keep to the part (0: the exact pieces; else the tolerance asked for, or a doubling of it when
    the count needed more, module doc)."""

    pieces: tuple[tuple[FPt, ...], ...]
    tolerance: float


def _box(poly) -> tuple[float, float, float, float]:
    return poly.bounds


def _near(a, b, slack: float) -> bool:
    return not (a[2] + slack < b[0] or b[2] + slack < a[0] or a[3] + slack < b[1]
                or b[3] + slack < a[1])


def _merge(polys: list, allowed, tol: float) -> list:
    """Greedy hull merges within ``allowed`` (a prepared region), least added area first."""
    import shapely
    from shapely.geometry import MultiPoint

    alive = dict(enumerate(polys))
    boxes = {k: _box(p) for k, p in alive.items()}
    heap: list = []

    def consider(i: int, j: int) -> None:
        if not _near(boxes[i], boxes[j], tol):
            return
        a, b = alive[i], alive[j]
        hull = MultiPoint(list(a.exterior.coords) + list(b.exterior.coords)).convex_hull
        if hull.geom_type != "Polygon" or not allowed.covers(hull):
            return
        extra = hull.area - (a.area + b.area - a.intersection(b).area)
        heapq.heappush(heap, (max(extra, 0.0), i, j, hull))

    keys = sorted(alive)
    for n, i in enumerate(keys):
        for j in keys[n + 1:]:
            consider(i, j)
    nxt = len(polys)
    while heap:
        _, i, j, hull = heapq.heappop(heap)
        if i not in alive or j not in alive:
            continue
        del alive[i], alive[j]
        k, nxt = nxt, nxt + 1
        alive[k] = shapely.normalize(hull)
        boxes[k] = _box(alive[k])
        for m in sorted(alive):
            if m != k:
                consider(m, k)
    return [alive[k] for k in sorted(alive)]


def _ccw(poly) -> tuple[FPt, ...]:
    from shapely.geometry.polygon import orient

    return tuple((float(x), float(y)) for x, y in list(orient(poly, 1.0).exterior.coords)[:-1])


def outline(part: Part, tolerance: float, max_pieces: int = 32) -> Outline:
    """The part's pieces for the simulator (module doc): exact when its exact convex pieces are at
    most ``max_pieces`` (at least 1), else merged within ``tolerance`` (assembly units; 0: start
    at a thousandth of the part's extent), doubled until at most ``max_pieces`` remain."""
    from shapely.geometry import Polygon
    from shapely.prepared import prep

    from rap.sim.shapes import convex_pieces

    cap = max(1, int(max_pieces))
    exact = [tuple((float(x), float(y)) for x, y in pc) for pc in convex_pieces(part)]
    if len(exact) <= cap:
        return Outline(tuple(exact), 0.0)
    shape = Polygon(part.float_outer(), part.float_holes())
    x0, y0, x1, y1 = shape.bounds
    tol = tolerance if tolerance > 0 else 1e-3 * max(x1 - x0, y1 - y0)
    polys = [Polygon(pc) for pc in exact]
    while True:
        polys = _merge(polys, prep(shape.buffer(tol, quad_segs=8)), tol)
        if len(polys) <= cap:
            return Outline(tuple(_ccw(p) for p in polys), tol)
        tol *= 2.0


def part_tolerance(part: Part, fraction: float) -> float:
    """``fraction`` of the part's extent (the larger side of its bounding box), in its units."""
    xs = [float(x) for x, _ in part.outer]
    ys = [float(y) for _, y in part.outer]
    return fraction * max(max(xs) - min(xs), max(ys) - min(ys))


@lru_cache(maxsize=64)
def assembly_outlines(assembly: Assembly, tolerance: float, max_pieces: int
                      ) -> dict[str, tuple[tuple[FPt, ...], ...]]:
    """Every part's simulator pieces (floats), keyed by part id: ``outline`` with the
    tolerance ``part_tolerance(part, tolerance)`` (a fraction of the part's own extent, so that in
    any simulation, whose frame spans at least the part, the shapes move by at most ``tolerance
    x world_size`` world units). Parts of at most ``max_pieces`` pieces are exactly
    ``rap.sim.shapes.assembly_pieces``'s. Memoised."""
    from rap.sim.shapes import assembly_pieces

    exact = assembly_pieces(assembly)
    return {part.id: exact[part.id] if len(exact[part.id]) <= max(1, max_pieces)
            else outline(part, part_tolerance(part, tolerance), max_pieces).pieces
            for part in assembly.parts}
