"""Parts as the faces of a drawing's arrangement: cut lines drawn once, T-junctions, borders.

``face_parts(paths, grid, source_kind) -> (parts, gaps_closed)`` for drawings whose parts are
not each drawn as a closed loop: a laser-cut sheet or a generated jigsaw (a border and cut lines
that end on it or on other cuts), touching parts with each shared edge drawn once.

1. *Gaps*: an open path's end that lies within the tolerance of another path but not on it is
   moved onto its nearest point there (a gap closed, counted).
2. *Noding with snap rounding*: every path, noded where paths cross or touch, is rounded to the
   tolerance's grid by GEOS's snap-rounding noder (``shapely.union_all(..., grid_size=step)``):
   each segment passing through a grid cell that holds a vertex or a crossing is routed through
   that cell's centre. Snap rounding never creates a crossing the drawing does not have (its
   output is fully noded), so every face below is a simple ring on the grid.
3. *Faces*: the bounded faces of the noded linework (``shapely.polygonize_full``), each with the
   faces nested in it as holes. A face's *depth* is the number of faces' holes that hold it:
   even-depth faces are parts, odd-depth faces are the cut-outs of the part around them, and a
   face inside a cut-out is a part again (a peg in a hole), as for closed loops
   (``rap.cad.parts``).
4. *Exact rings*: the grid coordinates become integer indices (``Grid``); shared boundaries are
   the same noded segments on both sides, so touching parts touch exactly. The importer then
   validates the assembly exactly, as for any drawing.

Parts are named ``piece-N`` in reading order (top to bottom, then left to right); each keeps the
source of a path on its boundary for messages. Cost: GEOS's noding, O((n + k) log n) for n
segments and k crossings, and polygonizing, O(n log n); then O(n) exact conversion.
"""

from __future__ import annotations

from rap.cad.arrangement.annotations import path_line
from rap.cad.drawing import DrawnPath, Problem, Source, distance
from rap.cad.parts import ExactPart, canonical_ring
from rap.cad.snap import Grid

__all__ = ["face_parts"]


def _closed_gaps(paths: list[DrawnPath], lines: list, tol: float) -> tuple[list, int]:
    """Lines with each open end within ``tol`` of another path moved onto it; gaps closed."""
    import shapely

    tree = shapely.STRtree(lines)
    out = list(lines)
    gaps = 0
    for i, p in enumerate(paths):
        if p.closed or distance(p.start, p.end) <= tol:
            continue
        coords = list(out[i].coords)
        for k in (0, len(coords) - 1):
            pt = shapely.Point(coords[k])
            best = None
            for j in tree.query(pt, predicate="dwithin", distance=tol):
                if j == i:
                    continue
                d = lines[j].distance(pt)
                if best is None or d < best[0]:
                    best = (d, j)
            if best is None or best[0] == 0:
                continue
            on = lines[best[1]].interpolate(lines[best[1]].project(pt))
            coords[k] = (on.x, on.y)
            gaps += 1
        out[i] = shapely.LineString(coords)
    return out, gaps


def face_parts(paths: list[DrawnPath], grid: Grid) -> tuple[list[ExactPart], int]:
    """The parts of a drawing as the faces of its arrangement (see the module doc)."""
    import shapely

    tol = grid.step_float
    lines, gaps = _closed_gaps(paths, [path_line(p) for p in paths], tol)
    noded = shapely.union_all(lines, grid_size=tol)
    polygons = shapely.get_parts(shapely.polygonize_full([noded])[0])
    faces = [f for f in polygons if f.area > 0]
    if not faces:
        raise Problem("no closed loop found: the lines bound no face")
    holes = [shapely.Polygon(h) for f in faces for h in f.interiors]
    hole_tree = shapely.STRtree(holes) if holes else None
    path_tree = shapely.STRtree(lines)
    chosen = []
    for f in faces:
        point = f.representative_point()
        depth = 0 if hole_tree is None else sum(
            1 for j in hole_tree.query(point, predicate="intersects") if holes[j].contains(point))
        if depth % 2 == 0:
            chosen.append((-point.y, point.x, f))
    chosen.sort(key=lambda t: (t[0], t[1]))
    parts = []
    for k, (_, _, f) in enumerate(chosen):
        j = int(path_tree.query_nearest(shapely.Point(f.exterior.coords[0]))[0])
        src: Source = paths[j].source
        outer = grid.ring(f.exterior.coords)
        inner = [grid.ring(h.coords) for h in f.interiors]
        if len(outer) < 3:
            continue
        parts.append(ExactPart(f"piece-{k + 1}", canonical_ring(outer, ccw=True),
                               [canonical_ring(h, ccw=False) for h in inner if len(h) >= 3], src,
                               src.layer, [src] * len(inner)))
    return parts, gaps
