"""Single-part mechanisms: does one part move under gravity when the parts around it hold still and
no contact is pre-stressed?

Why (``rap.sim.statics`` calls this before its equilibrium program): the program accepts any
equilibrium, including ones that need *pre-stress*: a brick whose centroid overhangs its support,
held up by friction against a neighbour that presses on it sideways, or a block wedged between two
vertical faces. Forces like these arise only if something squeezes the parts together; a pile
built by placing parts at rest has none, and the brick tips, the block falls (the settling
simulation, ``rap.sim.settling``, agrees). So, for each part alone, with every other part fixed,
two families of instantaneous motions are tried:

- *tipping*: a rotation, either way, about one of the part's contact points (the pivot) under
  which every contact point away from the pivot opens (its velocity has a positive component
  along the contact normal into the part). Contacts that open carry no force, the pivot alone
  cannot hold a torque: if gravity does non-negative work on the rotation (zero: a knife edge),
  the part tips;
- *sliding*: a translation along gravity or along a contact's tangent under which no contact
  closes; the contacts it slides along (normal perpendicular to the motion) hold it only by
  friction on the normal force that gravity presses on them (zero when gravity is parallel to
  them: a wedged block). The part slides when gravity's component along the motion exceeds
  ``friction`` times that normal force.

A motion found proves the parts unstable (under the no-pre-stress assumption); none found proves
nothing (mechanisms of several parts together are left to the program). Floats (physics):
contact points and the centroid in normalised units of order 1, decisions with the tolerance
``TOL``.

Cost: O(P K^2) for P parts of at most K contact points each, in one batch of numpy operations.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Mechanism", "part_mechanisms", "single_part_mechanism", "TOL"]

TOL = 1e-9


class Mechanism(tuple):
    """``(kind, where)``: kind ``"tip"`` with the pivot point, ``"slide"`` with the direction of
    motion, or ``"fall"`` with the direction of gravity."""

    __slots__ = ()

    def __new__(cls, kind: str, where: tuple[float, float]):
        return super().__new__(cls, (kind, where))

    @property
    def kind(self) -> str:
        return self[0]

    @property
    def where(self) -> tuple[float, float]:
        return self[1]


def _perp(v: np.ndarray) -> np.ndarray:
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _tipping(points, normals, valid, centroids, g) -> tuple[np.ndarray, np.ndarray]:
    """[P] whether each part tips, [P] the pivot's index."""
    # r[p, i, j] = point j - pivot i; velocity of j under a unit CCW rotation about i: perp(r)
    r = points[:, None, :, :] - points[:, :, None, :]
    vn = (_perp(r) * normals[:, None, :, :]).sum(axis=-1)  # [P, pivot, point], CCW rotation
    still = (np.hypot(r[..., 0], r[..., 1]) <= TOL) | ~valid[:, None, :]  # the pivot, padding
    power = (_perp(centroids[:, None, :] - points) * g).sum(axis=-1)  # [P, pivot], CCW
    tips = np.zeros(valid.shape, dtype=bool)
    for sense in (1.0, -1.0):
        tips |= (still | (sense * vn > TOL)).all(axis=2) & (sense * power > -TOL) & valid
    return tips.any(axis=1), tips.argmax(axis=1)


def _sliding(normals, valid, g, friction) -> tuple[np.ndarray, np.ndarray]:
    """[P] whether each part slides or falls, [P, 2] the direction of motion."""
    n_parts = len(normals)
    tangents = _perp(normals)
    dirs = np.concatenate([np.broadcast_to(g, (n_parts, 1, 2)), tangents, -tangents], axis=1)
    dir_ok = np.concatenate([np.ones((n_parts, 1), dtype=bool), valid, valid], axis=1)
    along = dirs @ g  # [P, C]
    dn = np.einsum("pkx,pcx->pkc", normals, dirs)
    closes = ((dn < -TOL) & valid[:, :, None]).any(axis=1)
    touching = (np.abs(dn) <= TOL) & valid[:, :, None]
    # the sliding contacts' normals are +m or -m, m = the direction turned left; gravity presses
    # the part onto contacts of normal +m with -g.m (if positive); with contacts on both sides
    # (a wedge) the least total normal force is |g.m|, all on one side
    m = _perp(dirs)
    side = np.einsum("pkx,pcx->pkc", normals, m) * touching
    plus, minus = (side > 0.5).any(axis=1), (side < -0.5).any(axis=1)
    gm = m @ g
    pressed = np.where(plus & minus, np.abs(gm),
                       np.where(plus, np.maximum(0.0, -gm), np.maximum(0.0, gm)))
    moves = dir_ok & (along > TOL) & ~closes & (along > friction * pressed + TOL)
    first = moves.argmax(axis=1)
    return moves.any(axis=1), dirs[np.arange(n_parts), first]


def part_mechanisms(points: np.ndarray, normals: np.ndarray, valid: np.ndarray,
                    centroids: np.ndarray, gravity: np.ndarray,
                    friction: float) -> list[Mechanism | None]:
    """For P parts at once: ``points`` and ``normals`` [P, K, 2] (contact points, unit normals
    into the part; rows padded to K, ``valid`` [P, K] marks the real ones), ``centroids`` [P, 2],
    ``gravity`` [2] a unit vector. Each part's motion with every other part fixed (see the module
    doc), or None: a tip when there is one, else a slide or a fall."""
    g = np.asarray(gravity, dtype=float)
    if points.shape[1] == 0:
        return [Mechanism("fall", (float(g[0]), float(g[1])))] * len(points)
    tips, pivot = _tipping(points, normals, valid, centroids, g)
    slides, where = _sliding(normals, valid, g, friction)
    out: list[Mechanism | None] = []
    for p in range(len(points)):
        if not valid[p].any():
            out.append(Mechanism("fall", (float(g[0]), float(g[1]))))
        elif tips[p]:
            x, y = points[p, pivot[p]]
            out.append(Mechanism("tip", (float(x), float(y))))
        elif slides[p]:
            d = where[p]
            free = not (np.abs(normals[p][valid[p]] @ d) <= TOL).any()
            kind = "fall" if free and np.allclose(d, g) else "slide"
            out.append(Mechanism(kind, (float(d[0]), float(d[1]))))
        else:
            out.append(None)
    return out


def single_part_mechanism(points: np.ndarray, normals: np.ndarray, centroid: np.ndarray,
                          gravity: np.ndarray, friction: float) -> Mechanism | None:
    """One part's motion (``part_mechanisms`` for a single part): ``points`` [k, 2] its contact
    points, ``normals`` [k, 2] the unit contact normals pointing into the part, ``centroid`` [2],
    ``gravity`` [2] a unit vector; the other parts are fixed."""
    pts = np.asarray(points, dtype=float).reshape(1, -1, 2)
    nrm = np.asarray(normals, dtype=float).reshape(1, -1, 2)
    return part_mechanisms(pts, nrm, np.ones(pts.shape[:2], dtype=bool),
                           np.asarray(centroid, dtype=float).reshape(1, 2), gravity,
                           friction)[0]
