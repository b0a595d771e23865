"""Geometric descriptors of an operation: the numbers a 64x64 image pair renders too coarsely.

An insertion under perpendicular actuation noise succeeds when the motion can deviate from its
direction without the moving subassembly jamming on the fixed one. How far it may deviate is exact
geometry: the maximal range of removal directions of the partition (moving, fixed) in the NDBG, and
where the operation's direction lies in it. A clearance of one unit in an assembly a hundred units
wide is a fraction of a pixel in the images, but it opens that range by about a degree. Beside the
range, a few shape numbers: contact lengths between the two subassemblies (sliding along the motion
or facing it), how deep the moving part sits inside the fixed one along the motion, the lateral
overlap, the sizes. ``DESCRIPTORS`` names them, in order:

* ``range_width_rad``: angular width of the maximal removal range (0 for a single direction, 2 pi
  when every direction is free), from the NDBG's exact critical directions;
* ``margin_rad``: angle from the removal direction to the nearer end of that range (pi for the
  whole circle); ``margin_fraction``: that margin over half the width (1 at the middle);
* ``single_direction``: 1 when the range is one critical direction;
* ``moving_parts``, ``fixed_parts``; ``log_area_fraction``: log of the moving area over both;
* ``sliding_contact``, ``facing_contact``: length of the common boundary of the two subassemblies
  parallel to the motion, and the rest projected across it, over the moving perimeter;
* ``depth``: how far the fixed subassembly reaches past the moving one's trailing end along the
  removal direction, over the moving extent; ``lateral_overlap``: overlap of the two across the
  motion, over the moving width; ``log_aspect``: log of the moving width across the motion over
  its length along it.

Every descriptor is invariant under translation, rotation, scaling and mirroring of the assembly
with its motion (so the mirror augmentation of training keeps them), and the same for every
direction drawn inside one range except the margins.

The range is exact (integer directions, ``rap.geometry``); the descriptors themselves are floats
(angles by ``atan2`` of the exact bounds, lengths with shapely): inputs of a learned model, never
predicates. The operation's cell is found from its direction: the exact one when the operation
carries it, else the float unit vector taken exactly; a float that lands beside a single-direction
range (a vertex cell, within 1e-9 rad) where the operation is not feasible is taken as that
vertex, which is what the float stood for.

Cost: building the NDBG once per assembly (``DescriptorContext``), then O(cells) integer work plus
a shapely union per distinct set of parts and a boundary intersection per distinct (moving,
fixed) pair (both cached): about 0.3 ms an operation, a quarter to a half of rendering its images
(``python -m research.benchmarks.descriptors``).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence

import numpy as np

from rap.assembly import Assembly
from rap.geometry.exact import IVec
from rap.geometry.ndbg import NDBG, cell_index, ndbg_of
from rap.operation import Operation

__all__ = ["DESCRIPTORS", "VERSION", "DescriptorContext", "operation_descriptors",
           "descriptors_for", "columns", "PARALLEL_COS", "VERTEX_RAD", "segments"]

VERSION = 1  # of the definitions below: caches of computed descriptors are keyed by it

DESCRIPTORS = ("range_width_rad", "margin_rad", "margin_fraction", "single_direction",
               "moving_parts", "fixed_parts", "log_area_fraction", "sliding_contact",
               "facing_contact", "depth", "lateral_overlap", "log_aspect")

_TWO_PI = 2.0 * math.pi
PARALLEL_COS = 0.999  # a contact edge within 2.6 degrees of the motion counts as sliding
VERTEX_RAD = 1e-9  # a float direction this close to a critical one may stand for it (rows keep
# only the float unit vector of an operation's direction; a vertex's is its exact direction's)


def _angle(v: Sequence[float]) -> float:
    return math.atan2(float(v[1]), float(v[0]))


def _ccw(a: Sequence[float], b: Sequence[float]) -> float:
    """CCW angle from direction a to direction b, in [0, 2 pi)."""
    return (_angle(b) - _angle(a)) % _TWO_PI


class DescriptorContext:
    """One assembly's NDBG, part polygons and caches, for the descriptors of its operations.

    Not thread-safe (caches). Memory: the NDBG, one union per distinct set of parts and one contact
    list per distinct (moving, fixed) pair."""

    def __init__(self, assembly: Assembly, ndbg: NDBG | None = None):
        self.assembly = assembly
        self.ndbg = ndbg if ndbg is not None else ndbg_of(assembly)
        self._polygons: dict[str, object] = {}
        self._unions: dict[frozenset, tuple] = {}
        self._shapes: dict[tuple[frozenset, frozenset], tuple] = {}

    def _feasible(self, k: int, moving: int, fixed: int) -> bool:
        outs = self.ndbg.cells[k].outs
        m = moving
        while m:
            low = m & -m
            if outs[low.bit_length() - 1] & fixed:
                return False
            m ^= low
        return True

    def removal_range(self, moving: frozenset[str], fixed: frozenset[str], removal: Sequence,
                      from_float: bool = False) -> tuple[IVec | None, IVec | None]:
        """(start, end) exact bounds of the maximal CCW range of removal directions of ``moving``
        off ``fixed`` that holds ``removal``: equal for a single direction, (None, None) for the
        whole circle. ``from_float``: ``removal`` is a float unit vector taken exactly, which may
        stand for a critical direction beside it (within ``VERTEX_RAD``). Raises ``ValueError``
        when the operation is not feasible there."""
        mv, fx = self.ndbg.mask(moving), self.ndbg.mask(fixed)
        cells = self.ndbg.cells
        n = len(cells)
        k0 = cell_index(self.ndbg, removal)
        if not self._feasible(k0, mv, fx):
            near = []
            if from_float:  # the vertex cell the float stood for, if it lies right beside it
                a = _angle(removal)
                near = [k for k in ((k0 - 1) % n, (k0 + 1) % n)
                        if cells[k].kind == "vertex" and self._feasible(k, mv, fx)
                        and min(abs(_angle(cells[k].direction) - a),
                                _TWO_PI - abs(_angle(cells[k].direction) - a)) < VERTEX_RAD]
            if not near:
                raise ValueError(f"moving {sorted(moving)} is blocked by {sorted(fixed)} along "
                                 f"{tuple(float(v) for v in removal)}")
            k0 = near[0]
        first, steps = k0, 0
        while steps < n - 1 and self._feasible((first - 1) % n, mv, fx):
            first, steps = (first - 1) % n, steps + 1
        if steps == n - 1:
            return None, None
        last = k0
        while self._feasible((last + 1) % n, mv, fx):
            last = (last + 1) % n
        a, b = cells[first], cells[last]
        start = a.direction if a.kind == "vertex" else a.start
        end = b.direction if b.kind == "vertex" else b.end
        return start, end

    def _union(self, ids: frozenset[str]) -> tuple:
        """(shapely union, its exterior vertices, area, perimeter) of a set of parts (cached)."""
        hit = self._unions.get(ids)
        if hit is None:
            from shapely.geometry import Polygon
            from shapely.ops import unary_union

            polygons = []
            for pid in sorted(ids):
                p = self._polygons.get(pid)
                if p is None:
                    part = self.assembly.part(pid)
                    p = self._polygons[pid] = Polygon(part.float_outer(), part.float_holes())
                polygons.append(p)
            g = unary_union(polygons)
            hit = self._unions[ids] = (g, _vertices(g), g.area, g.length)
        return hit

    def _shape(self, moving: frozenset[str], fixed: frozenset[str]) -> tuple:
        key = (moving, fixed)
        hit = self._shapes.get(key)
        if hit is None:
            m, mv, am, perimeter = self._union(moving)
            f, fv, af, _ = self._union(fixed)
            contact = segments(m.boundary.intersection(f.boundary))
            hit = self._shapes[key] = (mv, fv, contact, am, af, perimeter)
        return hit

    def descriptors(self, op: Operation) -> np.ndarray:
        """float32 [len(DESCRIPTORS)] of one feasible operation of this assembly."""
        ux, uy = op.direction
        r = (-ux, -uy)  # the removal direction
        exact = op.exact_direction is not None
        if exact:
            removal = (-Fraction(op.exact_direction[0]), -Fraction(op.exact_direction[1]))
        else:
            removal = (Fraction(r[0]), Fraction(r[1]))
        start, end = self.removal_range(op.moving, op.fixed, removal, from_float=not exact)
        if start is None:
            width, margin = _TWO_PI, math.pi
        elif start == end:
            width = margin = 0.0
        else:
            width = _ccw(start, end)
            margin = min(_ccw(start, r), _ccw(r, end))
            margin = min(margin, width / 2)  # a float direction on the boundary side
        mv, fv, contact, am, af, perimeter = self._shape(op.moving, op.fixed)
        sliding = facing = 0.0
        for (x0, y0, x1, y1) in contact:
            length = math.hypot(x1 - x0, y1 - y0)
            c = abs((x1 - x0) * r[0] + (y1 - y0) * r[1]) / length
            if c > PARALLEL_COS:
                sliding += length
            else:
                facing += length * math.sqrt(max(0.0, 1.0 - c * c))
        along = np.array(r)
        across = np.array((-r[1], r[0]))
        ma, fa, mc, fc = mv @ along, fv @ along, mv @ across, fv @ across
        length_along = max(float(ma.max() - ma.min()), 1e-12)
        width_across = max(float(mc.max() - mc.min()), 1e-12)
        extent = max(length_along, width_across)
        depth = max(0.0, float(fa.max() - ma.min())) / extent
        lateral = max(0.0, min(float(mc.max()), float(fc.max())) - max(float(mc.min()), float(fc.min())))
        return np.array([width, margin, margin / (width / 2) if width > 0 else 0.0,
                         float(start is not None and start == end),
                         len(op.moving), len(op.fixed), math.log(am / (am + af)),
                         sliding / perimeter, facing / perimeter, depth, lateral / width_across,
                         math.log(width_across / length_along)], dtype=np.float32)


def columns(names: Sequence[str]) -> list[int]:
    """Indices of the descriptors ``names`` in ``DESCRIPTORS`` (a network's subset, in its order)."""
    return [DESCRIPTORS.index(n) for n in names]


def _vertices(geom) -> np.ndarray:
    polys = getattr(geom, "geoms", [geom])
    return np.concatenate([np.asarray(p.exterior.coords) for p in polys])


def segments(geom) -> list[tuple[float, float, float, float]]:
    """The straight pieces of the line parts of a shapely geometry (points dropped)."""
    out = []
    stack = [geom]
    while stack:
        g = stack.pop()
        if g.geom_type in ("LineString", "LinearRing"):
            cs = list(g.coords)
            out += [(x0, y0, x1, y1) for (x0, y0), (x1, y1) in zip(cs, cs[1:])
                    if (x0, y0) != (x1, y1)]
        elif hasattr(g, "geoms"):
            stack.extend(g.geoms)
    return out


def operation_descriptors(assembly: Assembly, op: Operation,
                          context: DescriptorContext | None = None) -> np.ndarray:
    """float32 [len(DESCRIPTORS)] of one operation (builds the NDBG unless given a context)."""
    return (context or DescriptorContext(assembly)).descriptors(op)


def descriptors_for(context: DescriptorContext, ops: Sequence[Operation]) -> np.ndarray:
    """float32 [N, len(DESCRIPTORS)] for operations of the context's assembly."""
    out = np.empty((len(ops), len(DESCRIPTORS)), dtype=np.float32)
    for i, op in enumerate(ops):
        out[i] = context.descriptors(op)
    return out
