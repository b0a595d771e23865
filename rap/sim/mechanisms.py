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

Cost: O(k^2) for a part with k contact points (numpy), per part.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Mechanism", "single_part_mechanism", "TOL"]

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


def _tipping(points: np.ndarray, normals: np.ndarray, centroid: np.ndarray,
             g: np.ndarray) -> Mechanism | None:
    # r[i, j] = point j - pivot i; velocity of j under a unit CCW rotation about i: perp(r)
    r = points[None, :, :] - points[:, None, :]
    perp = np.stack([-r[..., 1], r[..., 0]], axis=-1)
    vn = (perp * normals[None, :, :]).sum(axis=-1)  # [pivot, point] normal velocity, CCW
    at_pivot = np.hypot(r[..., 0], r[..., 1]) <= TOL
    rc = centroid[None, :] - points
    power = -rc[:, 1] * g[0] + rc[:, 0] * g[1]  # gravity's power on a unit CCW rotation
    for sense in (1.0, -1.0):
        opens = (at_pivot | (sense * vn > TOL)).all(axis=1)
        tips = opens & (sense * power > -TOL)
        if tips.any():
            i = int(np.flatnonzero(tips)[0])
            return Mechanism("tip", (float(points[i, 0]), float(points[i, 1])))
    return None


def _sliding(normals: np.ndarray, g: np.ndarray, friction: float) -> Mechanism | None:
    tangents = np.stack([-normals[:, 1], normals[:, 0]], axis=1)
    for d in (g, *tangents, *(-tangents)):
        along = float(g @ d)
        if along <= TOL:
            continue
        dn = normals @ d
        if (dn < -TOL).any():
            continue  # the motion closes a contact
        touching = np.abs(dn) <= TOL
        if not touching.any():
            return Mechanism("fall" if d is g else "slide", (float(d[0]), float(d[1])))
        # the sliding contacts' normals are all +n or -n (perpendicular to d); gravity presses
        # the part onto those along +n with -g.n (if positive); with contacts on both sides
        # (a wedge) the least total normal force is |g.n|, all on one side
        n = normals[touching][0]
        two_sided = bool((normals[touching] @ n < 0).any())
        pressed = abs(float(g @ n)) if two_sided else max(0.0, -float(g @ n))
        if along > friction * pressed + TOL:
            return Mechanism("slide", (float(d[0]), float(d[1])))
    return None


def single_part_mechanism(points: np.ndarray, normals: np.ndarray, centroid: np.ndarray,
                          gravity: np.ndarray, friction: float) -> Mechanism | None:
    """A motion of one part (see the module doc), or None. ``points`` [k, 2] its contact points,
    ``normals`` [k, 2] the unit contact normals pointing into the part, ``centroid`` [2],
    ``gravity`` [2] a unit vector; the other parts are fixed."""
    if len(points) == 0:
        return Mechanism("fall", (float(gravity[0]), float(gravity[1])))
    return _tipping(points, normals, centroid, gravity) or _sliding(normals, gravity, friction)
