"""What in a drawing is not a part's outline: the paths an import leaves out, and why.

``sort_out(paths, tol) -> Sorting`` keeps the paths that can bound a part and counts the rest by
kind and layer, so that an annotation never stops an import. Rules, in order; each one is a
drafting convention, and each left-out path is reported (``Sorting.left_out``):

0. *reference layers*: a layer the drawing's editor locked (``Drawing.locked``: Inkscape's lock,
   a DXF layer's lock flag) with a path that runs through the inside of a closed outline on an
   unlocked layer is a template or construction drawing kept under the parts: all its paths are
   left out. A locked layer drawn apart from the others stays;
1. *construction*: a path drawn in a centre, hidden, phantom or dashed linetype (DXF) or with a
   stroke-dasharray (SVG) is a construction line, never an outline (``DrawnPath.construction``);
2. *open paths that bound nothing*: an open path with an end that meets no other kept path within
   the tolerance (not another path's end, not a point on another path: a T-junction meets) is a
   dimension, leader, hatch or construction line. Removing one can free another's end, so the
   rule repeats until nothing changes. A cut line that ends on a border or on another cut stays;
3. *loops*: closed paths, and loose paths joined end to end within their layer as
   ``rap.cad.loops.join_loops`` joins them; loose paths that do not all join (a branch, an end
   on another path's span) are a network of cut lines (``Sorting.networks``). Loops are then
   nested (a loop's *depth*: how many other loops hold it);
4. *drawn twice*: of two loops with the same outline (within the tolerance) at an even depth (a
   shape drawn once filled and once stroked), the later one is left out. At an odd depth they are a
   hole and the peg in it, and both stay;
5. *outlines of the parts' union*: a loop at an even depth whose inside is covered, to within the
   tolerance or 2% of its size, by two or more other loops, is a target outline or a sheet's
   border drawn again: left out;
6. *frames*: a loop at an even depth that holds loops touching each other (parts, not holes) and
   touches none of them is a frame drawn around the parts: left out;
7. *symbols*: a loop crossed end to end by a construction line (a scale or datum symbol: a box and
   its centre lines), holding nothing else, is left out;
8. *page bars*: where the page is known (an SVG's viewport), a loop that touches no other loop
   and runs along the page's whole width (or height) while thinner than a tenth of its height (or
   width) is page furniture (a title bar, a game's timebar), not a part.

Geometry here is floats (shapely), as the drawing's own coordinates are: these rules choose which
paths to read, and every kept path is then snapped and checked exactly. Cost: an STR-tree over the
paths, O(P log P) for P paths per repetition of rule 2; rules 4-7 compare each loop with the
loops near it.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from rap.cad.drawing import DrawnPath, distance

__all__ = ["Sorting", "sort_out", "path_line", "loop_polygon"]


@dataclass
class Sorting:
    """The paths kept (file order), those left out counted by ``(kind, layer)``, and whether
    the kept paths include networks of cut lines (so faces, not loops, make the parts)."""

    kept: list[DrawnPath]
    left_out: Counter = field(default_factory=Counter)
    networks: bool = False
    #: kept loops at an even depth: the parts the loops make (when there are no networks)
    loop_parts: int = 0


def _points(path: DrawnPath) -> list:
    pts = [path.pieces[0][0]]
    for piece in path.pieces:
        pts.extend(piece[1:])
    return pts


def path_line(path: DrawnPath):
    """The path as a shapely LineString (floats)."""
    import shapely

    pts = _points(path)
    return shapely.LineString(pts if len(pts) >= 2 else pts * 2)


def loop_polygon(path_or_points):
    """The polygon a closed path (or point list) bounds, repaired to a valid shapely polygon
    (a self-touching flattening is still the shape the user drew)."""
    import shapely

    pts = path_or_points if isinstance(path_or_points, list) else _points(path_or_points)
    if len(pts) < 3:
        return shapely.Polygon()
    poly = shapely.Polygon(pts)
    if not poly.is_valid:  # e.g. an outline pinched to a point: its polygonal part, whole
        fixed = shapely.make_valid(poly)
        polys = [g for g in shapely.get_parts(fixed) if g.geom_type in ("Polygon",
                                                                          "MultiPolygon")]
        poly = shapely.union_all(polys) if polys else shapely.Polygon()
    return poly


def _is_closed(path: DrawnPath, tol: float) -> bool:
    single = len(path.pieces) == 1 and len(path.pieces[0]) < 3
    return not single and (path.closed or distance(path.start, path.end) <= tol)


def _free_ends(paths: list[DrawnPath], kept: list[bool], tol: float) -> set[int]:
    """Indices of kept open paths with an end that meets no other kept path."""
    import numpy as np
    import shapely

    idx = [i for i, k in enumerate(kept) if k]
    lines = [path_line(paths[i]) for i in idx]
    tree = shapely.STRtree(lines)
    ends, owner = [], []
    for j, i in enumerate(idx):
        p = paths[i]
        if _is_closed(p, tol):
            continue
        ends += [p.start, p.end]
        owner += [j, j]
    if not ends:
        return set()
    pts = shapely.points(np.array(ends, dtype=float))
    hits = tree.query(pts, predicate="dwithin", distance=tol)
    met = [False] * len(ends)
    for e, g in zip(*hits):
        if g != owner[e]:
            met[e] = True
    return {idx[owner[e]] for e in range(len(ends)) if not met[e]}


@dataclass
class _Loop:
    members: list[int]  # path indices
    polygon: object
    depth: int = 0
    order: int = 0


def _loops(paths: list[DrawnPath], kept: list[bool], tol: float) -> tuple[list[_Loop], bool]:
    """The kept paths' loops (closed paths, and loose paths joined), and whether the loose
    paths are a network of cut lines instead (they do not all join into loops)."""
    loops: list[_Loop] = []
    open_idx = []
    for i, p in enumerate(paths):
        if not kept[i]:
            continue
        if _is_closed(p, tol):
            loops.append(_Loop([i], loop_polygon(p), order=p.source.order))
        else:
            open_idx.append(i)
    if open_idx:  # loose paths make loops exactly when the loop builder joins them all
        from rap.cad.drawing import Problem
        from rap.cad.loops import join_loops

        by_source = {id(paths[i].source): i for i in open_idx}
        try:
            joined = join_loops([paths[i] for i in open_idx], tol, "")
        except Problem:
            return loops, True
        for lp in joined:
            pts = [lp.pieces[0][0][0]] + [q for pc, _ in lp.pieces for q in pc[1:]]
            members = sorted({by_source[id(src)] for _, src in lp.pieces if id(src) in by_source})
            loops.append(_Loop(members, loop_polygon(pts), order=lp.source.order))
    loops.sort(key=lambda lp: lp.order)
    return loops, False


def _depths(loops: list[_Loop]) -> None:
    import shapely

    polys = [lp.polygon for lp in loops]
    tree = shapely.STRtree(polys)
    for k, lp in enumerate(loops):
        if lp.polygon.is_empty:
            continue
        point = lp.polygon.representative_point()
        lp.depth = sum(1 for j in tree.query(point, predicate="intersects")
                       if j != k and polys[j].area > lp.polygon.area
                       and polys[j].contains(point))


def _same(a, b, slack: float) -> bool:
    """Are two shapes' boundaries within ``slack`` of each other everywhere (Hausdorff distance
    of the boundaries, densified so that it measures along edges, not only at vertices)?"""
    if a.is_empty or b.is_empty:
        return False
    # cheap necessary conditions first: boxes within slack, areas within slack times perimeter
    if max(abs(u - v) for u, v in zip(a.bounds, b.bounds)) > slack:
        return False
    if abs(a.area - b.area) > slack * max(a.length, b.length):
        return False
    return shapely_hausdorff(a.boundary, b.boundary) <= slack


def _closed_union(polygons: list, slack: float):
    """The union of hand-placed pieces with the hairline gaps between them (narrower than
    ``slack``) closed and the holes left inside filled: the outline a person sees."""
    import shapely

    grown = shapely.union_all([p.buffer(slack / 2, join_style="mitre") for p in polygons])
    shrunk = grown.buffer(-slack / 2, join_style="mitre")
    return shapely.union_all([shapely.Polygon(g.exterior) for g in shapely.get_parts(shrunk)
                              if g.geom_type == "Polygon"])


def shapely_hausdorff(a, b) -> float:
    import shapely

    return float(shapely.hausdorff_distance(a, b, densify=0.05))


def _slack(poly, tol: float) -> float:
    return max(2 * tol, 0.02 * poly.area ** 0.5)


def _page_bar(poly, page, others: list, tol: float) -> bool:
    x0, y0, x1, y1 = poly.bounds
    px0, py0, px1, py1 = page
    pw, ph = px1 - px0, py1 - py0
    wide = (x1 - x0) >= 0.99 * pw and (y1 - y0) <= 0.1 * ph
    tall = (y1 - y0) >= 0.99 * ph and (x1 - x0) <= 0.1 * pw
    return (wide or tall) and all(poly.distance(q) > tol for q in others)


def _inside(loops: list[_Loop], k: int, alive: set[int], tree) -> list[int]:
    """The alive loops that loop k holds (smaller, a point of theirs inside it)."""
    poly = loops[k].polygon
    return [j for j in tree.query(poly, predicate="intersects") if j != k and j in alive
            and loops[j].polygon.area < poly.area
            and poly.contains(loops[j].polygon.representative_point())]


def _loop_rules(loops: list[_Loop], tol: float, page, construction: list, drop) -> bool:
    """Rules 4-8 on the loops, outermost first; ``drop(loop, why)`` leaves one out. True when
    a loop was left out (the paths left change, so rule 2 runs again)."""
    import shapely

    polys = [lp.polygon for lp in loops]
    tree = shapely.STRtree(polys)
    alive = {k for k, lp in enumerate(loops) if not lp.polygon.is_empty}
    holders = {k: [j for j in tree.query(polys[k].representative_point(), predicate="within")
                   if j != k and polys[j].area > polys[k].area] for k in alive}
    dropped = False

    def depth(k: int) -> int:
        return sum(1 for j in holders[k] if j in alive)

    def leave(k: int, why: str) -> None:
        nonlocal dropped
        drop(loops[k], why)
        alive.discard(k)
        dropped = True

    for k in sorted(alive, key=lambda k: -polys[k].area):
        if k not in alive or depth(k) % 2:
            continue
        poly = polys[k]
        twins = [j for j in tree.query(poly.buffer(2 * tol), predicate="contains")
                 if j != k and j in alive and depth(j) == depth(k)
                 and _same(poly, polys[j], 2 * tol)]
        if any(loops[j].order < loops[k].order for j in twins):  # rule 4
            leave(k, "shape drawn twice")
            continue
        inside = [j for j in _inside(loops, k, alive, tree) if j not in twins]
        top = [j for j in inside if not any(i != j and polys[i].area > polys[j].area
                                            and polys[i].contains(
                                                polys[j].representative_point())
                                            for i in inside)]
        if len(top) >= 2:
            slack = _slack(poly, tol)
            if _same(poly, _closed_union([polys[j] for j in top], slack), slack):  # rule 5
                leave(k, "outline of the parts' union")
                continue
            if not any(poly.boundary.distance(polys[j]) <= tol for j in top) \
                    and any(polys[a].distance(polys[b]) <= tol
                            for a in top for b in top if a < b):  # rule 6
                leave(k, "frame")
                continue
        if construction and not inside:  # rule 7
            ring = poly.boundary
            if any(ring.distance(shapely.Point(c.coords[0])) <= tol
                   and ring.distance(shapely.Point(c.coords[-1])) <= tol
                   and poly.contains(c.interpolate(0.5, normalized=True)) for c in construction):
                leave(k, "symbol")
                continue
        if page is not None and depth(k) == 0:  # rule 8
            others = [polys[j] for j in alive if j != k]
            if _page_bar(poly, page, others, tol):
                leave(k, "page bar")
    return dropped


def _reference_layers(paths: list[DrawnPath], locked: frozenset, tol: float) -> set[str]:
    """Rule 0: the locked layers with a path through the inside of an unlocked layer's loop."""
    import shapely

    drawn = {p.source.layer for p in paths}
    if not locked & drawn:
        return set()
    outlines = [loop_polygon(p) for p in paths
                if p.source.layer not in locked and _is_closed(p, tol)]
    inside = shapely.union_all(outlines).buffer(-tol) if outlines else shapely.Polygon()
    if inside.is_empty:
        return set()
    return {p.source.layer for p in paths if p.source.layer in locked
            and path_line(p).intersection(inside).length > tol}


def sort_out(paths: list[DrawnPath], tol: float, page=None, locked=frozenset()) -> Sorting:
    """Keep the paths that can bound a part (see the module doc); ``page``: the page's box in
    output units, when the drawing has one (rule 8); ``locked``: the locked layers (rule 0)."""
    left: Counter = Counter()
    reference = _reference_layers(paths, frozenset(locked), tol)
    kept = [p.construction is None and p.source.layer not in reference for p in paths]
    for p in paths:
        if p.source.layer in reference:
            left[("path of a locked layer drawn over a part", p.source.layer)] += 1
        elif p.construction is not None:
            left[(p.construction, p.source.layer)] += 1
    construction = [path_line(p) for p in paths if p.construction is not None]

    def drop(lp: _Loop, why: str) -> None:
        for i in lp.members:
            kept[i] = False
        left[(why, paths[lp.members[0]].source.layer)] += 1

    for _ in range(8):  # rules 2, then 4-8, until nothing changes (a frame gone frees ends)
        while True:  # rule 2
            free = _free_ends(paths, kept, tol)
            if not free:
                break
            for i in free:
                kept[i] = False
                left[("open path", paths[i].source.layer)] += 1
        loops, network = _loops(paths, kept, tol)
        if not loops or not _loop_rules(loops, tol, page, construction, drop):
            break
    _depths(loops)
    kept_paths = [p for p, k in zip(paths, kept) if k]
    outlines = sum(1 for lp in loops if not lp.polygon.is_empty and lp.depth % 2 == 0
                   and all(kept[i] for i in lp.members))
    return Sorting(kept_paths, left, network, outlines)
