"""Settling under gravity: an independent, dynamic check of static stability (pymunk).

``settle(assembly, ids, base, gravity)`` drops nothing: it starts the parts ``ids`` at rest in
their assembled places, the part ``base`` static (the fixture) and every other part a dynamic
rigid body of its convex pieces (``rap.sim.shapes.assembly_pieces``) with uniform density, lets
gravity act for ``seconds`` of simulated time and measures how far each part went. It shares no
code with ``rap.sim.statics`` (no contact table, no program): Chipmunk finds the contacts and
resolves them with its own iterative impulse solver.

Scene (constants ``SettlingParams``): the assembly is scaled so that its larger extent is
``world_size`` (100) world units; gravity is ``gravity_accel`` (1000) world units/s^2 along the
given direction (a 1 m assembly on Earth, at 1 world unit = 1 cm: unstable parts visibly fall,
slide or tip within a fraction of a second); Coulomb friction ``friction`` between every two
shapes (each shape gets ``sqrt(friction)``: Chipmunk multiplies the two shapes' coefficients);
no restitution; ``dt_s`` 1/240 s with ``iterations`` 40 solver iterations and a collision slop of
``collision_slop`` world units.

Measure: a part's displacement at a time is the largest distance any vertex of its pieces has
moved from its assembled place (rotation included); ``max_displacement`` is the largest over the
parts and over the sampled times (every ``sample_every`` steps), in assembly units. A part has
*moved* when its largest displacement exceeds ``moved_fraction`` (2%) of its own size (the larger
side of its bounding box); the parts are ``stable`` when none has moved.

Deterministic: no randomness; the bodies and shapes are added in sorted part order.
Cost: ``seconds / dt_s`` Chipmunk steps (480 by default) over the parts' pieces: about 10-50 ms
for the 22-brick wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np
import pymunk

from rap.assembly import Assembly
from rap.sim.shapes import area_centroid, assembly_pieces
from rap.sim.statics import DEFAULT_FRICTION, check_support_args

__all__ = ["Settling", "SettlingParams", "DEFAULT_SETTLING", "settle"]


@dataclass(frozen=True)
class SettlingParams:
    """Every constant of the settling simulation (see the module doc)."""

    world_size: float = 100.0
    gravity_accel: float = 1000.0  # world units / s^2
    dt_s: float = 1.0 / 240.0
    iterations: int = 40
    collision_slop: float = 0.01  # world units
    density: float = 1.0e-3
    sample_every: int = 4  # steps between displacement samples
    moved_fraction: float = 0.02  # of the part's size

    def to_dict(self) -> dict:
        return dict(self.__dict__)


DEFAULT_SETTLING = SettlingParams()


@dataclass(frozen=True)
class Settling:
    """How far the parts moved while settling: ``max_displacement`` in assembly units, the
    ``moved`` parts (sorted), ``stable`` when none moved; ``displacements`` per part (sorted by
    id, assembly units)."""

    max_displacement: float
    moved: tuple[str, ...]
    stable: bool
    displacements: tuple[tuple[str, float], ...] = ()


def settle(assembly: Assembly, ids: Iterable[str], base: str, gravity: tuple[float, float],
           seconds: float = 2.0, friction: float = DEFAULT_FRICTION,
           params: SettlingParams = DEFAULT_SETTLING) -> Settling:
    """Let the parts ``ids`` settle on the fixed part ``base`` under ``gravity`` (a direction) for
    ``seconds``; see the module doc. ``ValueError`` when ``base`` is not in ``ids``, gravity is
    zero or friction negative; ``KeyError`` for an unknown part."""
    chosen = sorted(set(ids))
    gx, gy, norm = check_support_args(assembly, chosen, base, gravity, friction)

    x0, y0, x1, y1 = assembly.bounds()
    scale = params.world_size / max(x1 - x0, y1 - y0)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    pieces = assembly_pieces(assembly)
    shape_mu = math.sqrt(friction)

    space = pymunk.Space()
    space.gravity = (params.gravity_accel * gx / norm, params.gravity_accel * gy / norm)
    space.iterations = params.iterations
    space.collision_slop = params.collision_slop

    def world(poly):
        return [((x - cx) * scale, (y - cy) * scale) for x, y in poly]

    def shape(body, poly):
        sh = pymunk.Poly(body, poly)
        sh.friction, sh.elasticity = shape_mu, 0.0
        return sh

    space.add(*(shape(space.static_body, world(pc)) for pc in pieces[base]))
    movers = [p for p in chosen if p != base]
    bodies, local, origin, size = [], [], [], []
    for pid in movers:
        polys = [world(pc) for pc in pieces[pid]]
        _, gx0, gy0 = area_centroid(polys)
        body = pymunk.Body()
        body.position = (gx0, gy0)
        shapes = []
        for poly in polys:
            sh = shape(body, [(x - gx0, y - gy0) for x, y in poly])
            sh.density = params.density
            shapes.append(sh)
        space.add(body, *shapes)
        bodies.append(body)
        verts = np.array([v for poly in polys for v in poly]) - (gx0, gy0)
        local.append(verts)
        origin.append(np.array([gx0, gy0]))
        size.append(float(np.ptp(verts, axis=0).max()) / scale)

    worst = np.zeros(len(movers))
    steps = max(1, int(round(seconds / params.dt_s)))
    for step in range(1, steps + 1):
        space.step(params.dt_s)
        if step % params.sample_every and step != steps:
            continue
        for k, body in enumerate(bodies):
            c, s = math.cos(body.angle), math.sin(body.angle)
            v = local[k]
            moved_to = v @ np.array([[c, s], [-s, c]]) + np.array(body.position)
            d = float(np.sqrt(((moved_to - v - origin[k]) ** 2).sum(axis=1)).max()) / scale
            worst[k] = max(worst[k], d)
    moved = tuple(p for p, d, sz in zip(movers, worst, size) if d > params.moved_fraction * sz)
    return Settling(max_displacement=float(worst.max()) if movers else 0.0, moved=moved,
                    stable=not moved,
                    displacements=tuple((p, float(d)) for p, d in zip(movers, worst)))
