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

Cost: ``mechanism_table`` does the work that depends on the parts' contact points, gravity and
friction only, O(P K^2) for P parts of at most K contact points each, in one batch of numpy
operations; ``first_mechanism`` then answers for any subset of the points (which contacts are
present) in O(P K^2) boolean operations, a few numpy calls (tens of microseconds for the
22-brick wall). ``part_mechanisms`` is the two together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Mechanism", "MechanismTable", "first_mechanism", "mechanism_table",
           "part_mechanisms", "single_part_mechanism", "TOL"]

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


@dataclass(frozen=True)
class MechanismTable:
    """What ``first_mechanism`` needs of P parts, K contact points each (padded), under one gravity
    and friction: every test of the module doc with the presence of the contacts left open. Each
    row of ``masks`` is a set of a part's points, as bits (point k: bit k % 64 of word k // 64):
    2K tipping rows (pivot i counter-clockwise, then clockwise: the points that do not open, all
    of them when gravity does not drive the rotation), then for each of the C candidate slides
    (gravity, the tangents, minus the tangents) three: the points that close; that are slid along
    with their normal on the left of the motion; on the right."""

    points: np.ndarray  # [P, K, 2] contact points
    normals: np.ndarray  # [P, K, 2] unit normals into the part
    gravity: np.ndarray  # [2] unit
    masks: np.ndarray  # [P, 2K + 3C, W] uint64, as above
    bits: np.ndarray  # [K, W] uint64: point k's bit
    dirs: np.ndarray  # [P, C, 2] the candidate slides
    beats: np.ndarray  # [P, C, 8] bool: slide c goes, by closes + 2 any-left + 4 any-right


def _bits(k: int) -> np.ndarray:
    out = np.zeros((k, max(1, -(-k // 64))), dtype=np.uint64)
    out[np.arange(k), np.arange(k) // 64] = np.uint64(1) << (np.arange(k) % 64).astype(np.uint64)
    return out


def mechanism_table(points: np.ndarray, normals: np.ndarray, centroids: np.ndarray,
                    gravity: np.ndarray, friction: float) -> MechanismTable:
    """The table of P parts: ``points`` and ``normals`` [P, K, 2] (contact points, unit normals
    into the part), ``centroids`` [P, 2], ``gravity`` [2] a unit vector. O(P K^2)."""
    g = np.asarray(gravity, dtype=float)
    n_parts, k = points.shape[:2]
    # tipping: r[p, i, j] = point j - pivot i; velocity of j under a unit CCW rotation about i
    r = points[:, None, :, :] - points[:, :, None, :]
    vn = (_perp(r) * normals[:, None, :, :]).sum(axis=-1)  # [P, pivot, point], CCW rotation
    pivot = np.hypot(r[..., 0], r[..., 1]) <= TOL
    power = (_perp(centroids[:, None, :] - points) * g).sum(axis=-1)  # [P, pivot], CCW
    blocks = [~(pivot | (s * vn > TOL)) | ~(s * power > -TOL)[..., None] for s in (1.0, -1.0)]
    # sliding
    tangents = _perp(normals)
    dirs = np.concatenate([np.broadcast_to(g, (n_parts, 1, 2)), tangents, -tangents], axis=1)
    along = dirs @ g  # [P, C]
    dn = np.einsum("pkx,pcx->pkc", normals, dirs)
    touching = np.abs(dn) <= TOL
    # the sliding contacts' normals are +m or -m, m = the direction turned left; gravity presses
    # the part onto contacts of normal +m with -g.m (if positive); with contacts on both sides
    # (a wedge) the least total normal force is |g.m|, all on one side
    m = _perp(dirs)
    side = np.einsum("pkx,pcx->pkc", normals, m) * touching
    gm = m @ g
    pressed = np.stack([np.maximum(0.0, gm), np.maximum(0.0, -gm), np.maximum(0.0, gm),
                        np.abs(gm)], axis=-1)  # by (any left) + 2 (any right)
    moves = (along > TOL)[..., None] & (along[..., None] > friction * pressed + TOL)
    beats = np.stack([moves, np.zeros_like(moves)], axis=-1)  # a closing slide never goes
    slides = np.stack([dn < -TOL, side > 0.5, side < -0.5], axis=3)  # [P, K, C, 3]
    flags = np.concatenate([*blocks, slides.reshape(n_parts, k, -1).transpose(0, 2, 1)], axis=1)
    bits = _bits(k)
    masks = flags.astype(np.uint64) @ bits
    return MechanismTable(points, normals, g, masks, bits, dirs, beats.reshape(n_parts, -1, 8))


def _verdicts(t: MechanismTable, rows: np.ndarray, valid: np.ndarray):
    """[n] tips, [n] pivot index, [n] slides, [n] slide index, for the parts ``rows``."""
    n, k = valid.shape
    hit = t.masks[rows] & (valid.astype(np.uint64) @ t.bits)[:, None, :]
    hits = hit[..., 0] != 0
    for w in range(1, hit.shape[2]):
        hits |= hit[..., w] != 0
    tip = ~hits[:, :2 * k]
    tip = (tip[:, :k] | tip[:, k:]) & valid
    code = hits[:, 2 * k:].reshape(n, -1, 3) @ np.array([1, 2, 4])  # [n, C]
    slide = t.beats[rows[:, None], np.arange(code.shape[1]), code]
    slide[:, 1:] &= np.concatenate([valid, valid], axis=1)  # the tangents of absent points
    first_tip, first_slide = tip.argmax(axis=1), slide.argmax(axis=1)
    at = np.arange(n)
    return tip[at, first_tip], first_tip, slide[at, first_slide], first_slide


def _mechanism(t: MechanismTable, row: int, valid: np.ndarray, tips: bool, pivot: int,
               slides: bool, first: int) -> Mechanism | None:
    g = t.gravity
    if not valid.any():
        return Mechanism("fall", (float(g[0]), float(g[1])))
    if tips:
        x, y = t.points[row, pivot]
        return Mechanism("tip", (float(x), float(y)))
    if slides:
        d = t.dirs[row, first]
        free = not (np.abs(t.normals[row][valid] @ d) <= TOL).any()
        kind = "fall" if free and np.allclose(d, g) else "slide"
        return Mechanism(kind, (float(d[0]), float(d[1])))
    return None


def first_mechanism(table: MechanismTable, rows: np.ndarray,
                    valid: np.ndarray) -> tuple[int, Mechanism] | None:
    """The first of the parts ``rows`` (indices into the table) that moves with every other part
    fixed when only its contact points marked in ``valid`` [len(rows), K] are present, as
    (position in ``rows``, its motion: a tip when there is one, else a slide or a fall); None
    when no part moves."""
    rows = np.asarray(rows, dtype=np.intp)
    if len(rows) == 0:
        return None
    if table.points.shape[1] == 0:
        g = table.gravity
        return 0, Mechanism("fall", (float(g[0]), float(g[1])))
    tips, pivot, slides, first = _verdicts(table, rows, valid)
    hit = tips | slides | ~valid.any(axis=1)
    if not hit.any():
        return None
    p = int(hit.argmax())
    return p, _mechanism(table, int(rows[p]), valid[p], bool(tips[p]), int(pivot[p]),
                         bool(slides[p]), int(first[p]))


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
    table = mechanism_table(points, normals, centroids, g, friction)
    rows = np.arange(len(points))
    verdicts = _verdicts(table, rows, valid)
    return [_mechanism(table, p, valid[p], *(bool(v[p]) if i % 2 == 0 else int(v[p])
                                             for i, v in enumerate(verdicts)))
            for p in rows]


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
