"""Parts drawn as loops that overlap or cross by less than the tolerance: hand-placed pieces.

``overlay_parts(loops, grid) -> parts`` for closed loops (``rap.cad.loops.join_loops``) that the
exact ring builder refuses: pieces placed by hand whose edges overlap by a hair, or a curve whose
rounding to the grid folds it onto itself at a cusp.

1. Each loop is a float polygon; nesting makes parts (a loop held by an even number of loops is
   a part's outline, the loops directly inside it its holes), as ``rap.cad.parts`` does exactly.
2. Every loop's boundary is noded and rounded to the tolerance's grid by snap rounding (GEOS,
   ``shapely.union_all(..., grid_size=step)``), which never creates a crossing the drawing does
   not have, and the faces of the result are found (``shapely.polygonize``).
3. Each face belongs to the parts whose polygon holds a point inside it. A face held by one part
   is that part's; by none, a gap or a hole. A face held by two or more is an overlap: when it is
   no thicker than the tolerance (twice its area over its perimeter, a sliver's width) it goes to
   the earliest of them in file order, and the later one gives it up; a thicker one is a
   ``Problem`` naming both parts, the overlap's area and depth.
4. A part is the union of its faces, on the grid: shared boundaries are the same noded segments on
   both sides, so pieces that overlapped now touch exactly. A part that the overlaps cut in two is
   a ``Problem``.

Cost: GEOS noding and polygonizing, O((n + k) log n) for n segments and k crossings, and a point
query per face. Floats choose which face is whose; the parts come out as exact grid indices and
are validated exactly by the importer.
"""

from __future__ import annotations

from rap.cad.arrangement.annotations import loop_polygon
from rap.cad.drawing import Problem
from rap.cad.loops import Loop
from rap.cad.parts import ExactPart, canonical_ring, loop_part_ids
from rap.cad.snap import Grid

__all__ = ["overlay_parts"]


def _points(loop: Loop) -> list:
    return [loop.pieces[0][0][0]] + [q for pc, _ in loop.pieces for q in pc[1:]]


def _nesting(polys: list) -> list[tuple[int, list[int]]]:
    """(outline loop, hole loops) of each part, by containment of representative points."""
    held = []
    for k, p in enumerate(polys):
        point = p.representative_point()
        held.append([j for j, q in enumerate(polys)
                     if j != k and (q.area > p.area or (q.area == p.area and j < k))
                     and q.contains(point)])
    parts = []
    for k in range(len(polys)):
        if len(held[k]) % 2 == 0:
            holes = [j for j in range(len(polys)) if len(held[j]) == len(held[k]) + 1
                     and k in held[j]]
            parts.append((k, holes))
    return parts


def overlay_parts(loops: list[Loop], grid: Grid, unit: str) -> list[ExactPart]:
    """The parts of loops that overlap by at most the tolerance (see the module doc)."""
    import shapely

    tol = grid.step_float
    polys = [loop_polygon(_points(lp)) for lp in loops]
    nested = _nesting(polys)
    shapes = [shapely.difference(polys[k], shapely.union_all([polys[h] for h in holes]))
              if holes else polys[k] for k, holes in nested]
    rings = shapely.union_all([shapely.LinearRing(_points(lp)) for lp in loops], grid_size=tol)
    faces = [f for f in shapely.get_parts(shapely.polygonize([rings])) if f.area > 0]
    owned: list[list] = [[] for _ in nested]
    for f in faces:
        point = f.representative_point()
        owners = [i for i, s in enumerate(shapes) if s.contains(point)]
        if not owners:
            continue
        if len(owners) > 1:
            depth = 2 * f.area / f.length
            if depth > tol:
                a, b = (loops[nested[i][0]].source for i in owners[:2])
                raise Problem(f"{a.describe()} and {b.describe()}: the parts overlap by "
                              f"{f.area:.6g} {unit}^2, {depth:.3g} {unit} deep, more than the "
                              f"tolerance {grid.step:f} {unit}")
        owned[min(owners, key=lambda i: loops[nested[i][0]].source.order)].append(f)
    ids = loop_part_ids([loops[k].source for k, _ in nested])
    out: list[ExactPart] = []
    for (k, holes), pid, fs in zip(nested, ids, owned):
        src = loops[k].source
        if not fs:
            raise Problem(f"{src.describe()}: the part vanishes on the grid of the tolerance "
                          f"{grid.step:f} {unit} (other parts cover it)")
        shape = shapely.union_all(fs, grid_size=tol)
        pieces = [g for g in shapely.get_parts(shape) if g.geom_type == "Polygon"]
        if len(pieces) != 1:
            raise Problem(f"{src.describe()}: the overlaps of other parts cut it in "
                          f"{len(pieces)} pieces")
        (poly,) = pieces
        outer = grid.ring(poly.exterior.coords)
        inner = [grid.ring(h.coords) for h in poly.interiors]
        out.append(ExactPart(pid, canonical_ring(outer, ccw=True),
                             [canonical_ring(h, ccw=False) for h in inner if len(h) >= 3], src,
                             src.layer, [loops[h].source for h in holes][:len(inner)]
                             + [src] * max(0, len(inner) - len(holes))))
    out.sort(key=lambda p: p.source.order)
    return out
