"""Static equilibrium of parts under gravity with Coulomb friction: a linear program over contact
forces.

Model: the parts ``ids`` stand on the part ``base``, which is fixed (the fixture) and may take
any force. Every other part is a rigid body of uniform density (mass = area) pulled along
``gravity`` (a direction; its magnitude does not matter). Parts touch along the contacts of
``rap.geometry.contacts`` between parts of ``ids`` only (vertex-vertex touching carries nothing).
The force that part ``a`` exerts on part ``b`` across a contact segment is represented by forces
at the segment's two end points (one point for a point contact): for a planar rigid contact any
admissible distribution of pressure and friction along a segment is equivalent to such a pair, so
this is exact. Each end point force lies in the Coulomb cone ``|f_t| <= mu f_n`` with ``f_n >= 0``
(no glue), written exactly in 2D as the non-negative combination of its two edge rays
``n + mu t`` and ``n - mu t`` (``n`` the unit normal from ``a`` into ``b``, ``t`` the tangent).
Newton's third law: ``b`` feels the force, ``a`` its opposite. Every non-base part must be in
equilibrium of force and torque (about its centroid). The parts are statically stable when the
program is feasible and no single part has a mechanism (below): ``Support.stable``.

Pre-stress: the program accepts any equilibrium, also one that needs parts squeezed together (a
brick overhanging its support, held by friction against a neighbour that presses on it sideways;
a block wedged between two vertical faces). A pile built by placing parts at rest has no such
forces, and those parts move. So before the program, ``rap.sim.mechanisms`` tries each part
alone, the others fixed: a rotation about one of its contact points that opens all its other
contacts and that gravity drives, or a slide that friction on the gravity-pressed contacts cannot
hold; one found makes the parts unstable. Mechanisms of several parts together that need
pre-stress are not caught. Measured on 700 random subsets of the 22-brick wall grown from the
plate: the verdict agreed with the settling simulation (``rap.sim.settling``) on all but 20, all
knife-edge states (a brick's centroid exactly above a corner) that this check rejects and the
simulation's perfect symmetry holds; none that it accepts falls. (The program alone accepted 15 of
the first 150 that fall.)

Margin: with ``margin = 0`` the forces act at the segments' end points and the check is exact
for rigid parts; but then a knife-edge balance passes (a brick whose centroid lies exactly above
the corner of the one brick under it: a force at that corner balances it), which no real pile
and no simulation holds. So by default (``DEFAULT_MARGIN``) each end point of a contact segment
is moved inwards by 5% of the segment's length before the forces are placed: a part must be
balanced with some room to spare. Point contacts (a vertex on an edge) are not moved.

Scaling, so that HiGHS's absolute tolerances (1e-7) mean something: lengths in units of the
assembly's larger extent, about its bounding box's centre; masses in units of the mean part area.
Decisions within those tolerances of the tipping or sliding limit (a centroid exactly above a
support corner, a slope exactly at the friction angle) may go either way.

The base alone is stable; a non-base part with no contact in ``ids`` is not. When the parts
are not stable, ``Support.reason`` names them in one line: parts that touch nothing, parts that
are not connected to the base through contacts, else the parts that need the most help in an
elastic version of the program (slack forces and torques, least total slack).

Cost: per geometry hash (and margin) the contact table and per-part arrays are built once, and
per gravity and friction the single-part mechanism table (``rap.sim.mechanisms``) and the
program's coefficients, O(P K^2) for P parts of at most K contact points each. A call then costs
a connectivity walk over bit masks, a few numpy operations that slice those tables by the subset's
mask, and, only when no part moves alone, one LP (``rap.sim.lp``: HiGHS without scipy's wrapper)
on a (3 x parts) by (2 x contact points) matrix, plus a second, elastic one to name the parts
when it is infeasible. On the 22-brick wall: about 0.1 ms when a part moves alone, 1 to 2 ms with
the program; the ~10,000 checks of the planner's ``reachable()`` with the plate as base take about
4.5 s CPU, against 18.5 s through scipy's ``linprog`` and per-call contact loops before
(``benchmarks/statics.py`` prints the figures). Results are memoised per ``(geometry hash,
frozenset(ids), base, gravity, friction, margin)`` in a bounded LRU cache (``CACHE_SIZE``
entries); it is thread-safe.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from rap.assembly import Assembly, area_moments
from rap.geometry.contacts import contact_table
from rap.geometry.moving_sets import closure
from rap.sim.lp import solve_lp
from rap.sim.mechanisms import MechanismTable, first_mechanism, mechanism_table

__all__ = ["DEFAULT_FRICTION", "DEFAULT_MARGIN", "Support", "check_static", "check_support_args",
           "clear_results", "CACHE_SIZE"]

DEFAULT_FRICTION = 0.5
DEFAULT_MARGIN = 0.05  # of each contact segment's length, at each end (see the module doc)
CACHE_SIZE = 65536
_BLAME_SLACK = 1e-6  # elastic LP: slack above this (in units of the part's weight) names a part


@dataclass(frozen=True)
class Support:
    """The verdict of ``check_static``: ``reason`` is one line naming the part(s) when not
    stable."""

    stable: bool
    reason: str = ""


@dataclass(frozen=True)
class _Geometry:
    """Per-assembly data in normalised units (see the module doc); parts by row (the assembly's
    order)."""

    ids: tuple[str, ...]  # row -> part id
    row: dict  # part id -> row
    mass: np.ndarray  # [N] area / mean area
    centroid: np.ndarray  # [N, 2] normalised
    size: float  # the assembly's larger extent: one normalised length unit
    center: tuple[float, float]  # the origin of the normalised coordinates
    neighbours: tuple[int, ...]  # row -> bit mask of the rows it touches
    points: np.ndarray  # [M, 4] every contact point: x, y, unit normal (a into b); pairs sorted
    point_a: np.ndarray  # [M] row of the pair's first part
    point_b: np.ndarray  # [M] row of the pair's second part
    own_points: np.ndarray  # [N, K, 4]: each part's contact points, normals into it, padded
    partner: np.ndarray  # [N, K]: the row of the part across each point (N: padding)


def _centroid_area(part) -> tuple[float, float, float]:
    """Exact area and centroid of a part (holes included), returned as floats."""
    a2, cx6, cy6 = area_moments(part.rings())
    return float(a2 / 2), float(cx6 / (3 * a2)), float(cy6 / (3 * a2))


def _contact_rows(contacts, margin, cx, cy, size) -> np.ndarray:
    rows = []
    for c in contacts:
        nx, ny = float(c.normal[0]), float(c.normal[1])
        norm = math.hypot(nx, ny)
        (px, py), (qx, qy) = ((float(v[0]), float(v[1])) for v in (c.p, c.q))
        ends = [(px, py)] if c.p == c.q else [
            (px + margin * (qx - px), py + margin * (qy - py)),
            (qx - margin * (qx - px), qy - margin * (qy - py))]
        for x, y in ends:
            rows.append(((x - cx) / size, (y - cy) / size, nx / norm, ny / norm))
    return np.array(rows, dtype=float).reshape(-1, 4)


def _build(assembly: Assembly, margin: float) -> _Geometry:
    x0, y0, x1, y1 = assembly.bounds()
    size = max(x1 - x0, y1 - y0)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    data = [_centroid_area(p) for p in assembly.parts]
    mean_area = sum(a for a, _, _ in data) / len(data)
    mass = np.array([a / mean_area for a, _, _ in data])
    centroid = np.array([((x - cx) / size, (y - cy) / size) for _, x, y in data]).reshape(-1, 2)
    row = {pid: i for i, pid in enumerate(assembly.ids)}
    neighbours = [0] * len(row)
    blocks, ends = [], []
    own: list[list[np.ndarray]] = [[] for _ in row]  # each part's points, normals into it
    across: list[list[int]] = [[] for _ in row]
    for (a, b), contacts in contact_table(assembly).items():
        pts = _contact_rows(contacts, margin, cx, cy, size)
        ia, ib = row[a], row[b]
        neighbours[ia] |= 1 << ib
        neighbours[ib] |= 1 << ia
        blocks.append(pts)
        ends += [(ia, ib)] * len(pts)
        own[ib].append(pts)
        across[ib] += [ia] * len(pts)
        own[ia].append(np.concatenate([pts[:, :2], -pts[:, 2:]], axis=1))
        across[ia] += [ib] * len(pts)
    points = np.concatenate(blocks) if blocks else np.zeros((0, 4))
    ends_ab = np.array(ends, dtype=np.intp).reshape(-1, 2)
    k = max([len(x) for x in across] + [1])
    own_points = np.zeros((len(row), k, 4))
    partner = np.full((len(row), k), len(row), dtype=np.intp)
    for i, parts in enumerate(own):
        if parts:
            own_points[i, :len(across[i])] = np.concatenate(parts)
            partner[i, :len(across[i])] = across[i]
    return _Geometry(tuple(assembly.ids), row, mass, centroid, size, (cx, cy),
                     tuple(neighbours), points, ends_ab[:, 0], ends_ab[:, 1], own_points,
                     partner)


@dataclass(frozen=True)
class _Loads:
    """Per geometry, gravity and friction: the mechanism table and the program's coefficients.
    Column j < M of the program is the ray ``n + mu t`` at contact point j, column M + j the ray
    ``n - mu t``; ``on_b`` [2M, 3] is what it adds to the second part's force and torque rows,
    ``on_a`` to the first part's."""

    mechanisms: MechanismTable
    on_b: np.ndarray
    on_a: np.ndarray


def _build_loads(geo: _Geometry, g: tuple[float, float], mu: float) -> _Loads:
    own = geo.own_points
    table = mechanism_table(own[..., :2], own[..., 2:], geo.centroid, np.array(g), mu)
    pts = geo.points
    n, t = pts[:, 2:4], np.stack([-pts[:, 3], pts[:, 2]], axis=1)
    rays = np.concatenate([n + mu * t, n - mu * t])  # [2M, 2]: force on b per unit weight
    xy = np.concatenate([pts[:, :2], pts[:, :2]])
    coefs = []
    for owner, sign in ((geo.point_b, 1.0), (geo.point_a, -1.0)):
        f = sign * rays
        r = xy - geo.centroid[np.concatenate([owner, owner])]
        coefs.append(np.stack([f[:, 0], f[:, 1], r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]], axis=1))
    return _Loads(table, coefs[0], coefs[1])


_GEOMETRY: OrderedDict[tuple, _Geometry] = OrderedDict()
_LOADS: OrderedDict[tuple, _Loads] = OrderedDict()
_RESULTS: OrderedDict[tuple, Support] = OrderedDict()
_LOCK = threading.Lock()


def _memo(cache: OrderedDict, key: tuple, make, size: int = 32):
    with _LOCK:
        hit = cache.get(key)
        if hit is not None:
            cache.move_to_end(key)
            return hit
    made = make()
    with _LOCK:
        cache[key] = made
        while len(cache) > size:
            cache.popitem(last=False)
    return made


def _geometry(assembly: Assembly, margin: float) -> _Geometry:
    return _memo(_GEOMETRY, (assembly.geometry_hash, margin), lambda: _build(assembly, margin))


def _names(parts: list[str]) -> str:
    quoted = ", ".join(repr(p) for p in parts[:5]) + (", ..." if len(parts) > 5 else "")
    return f"part {quoted}" if len(parts) == 1 else f"parts {quoted}"


def _connectivity_reason(geo: _Geometry, rows: list[int], base: int) -> str:
    """A reason when some part of ``rows`` touches nothing or is cut off from the base, else ''
    (a walk over bit masks of rows)."""
    nb, chosen = geo.neighbours, sum(1 << r for r in rows)
    alone = sorted(geo.ids[r] for r in rows if r != base and not nb[r] & chosen)
    if alone:
        return f"{_names(alone)} {'touches' if len(alone) == 1 else 'touch'} no other part"
    seen = closure(1 << base, nb, chosen)
    cut = sorted(geo.ids[r] for r in rows if not seen >> r & 1)
    if cut:
        return f"{_names(cut)} {'rests' if len(cut) == 1 else 'rest'} on nothing connected to " \
               f"the base {geo.ids[base]!r}"
    return ""


def _system(geo: _Geometry, loads: _Loads, present: np.ndarray, movers: np.ndarray,
            g: tuple[float, float]):
    """A_eq, b_eq of the equilibrium of the parts ``movers`` (rows, 3 equations each, in this
    order) among the parts ``present`` (a bool mask over rows), and the movers' masses."""
    at = np.full(len(geo.ids), -1, dtype=np.intp)
    at[movers] = np.arange(len(movers))
    sel = present[geo.point_a] & present[geo.point_b]
    sel = np.concatenate([sel, sel])
    a_eq = np.zeros((3 * len(movers), int(sel.sum())))
    cols = np.arange(a_eq.shape[1])
    for owner, coef in ((geo.point_b, loads.on_b), (geo.point_a, loads.on_a)):
        k = at[np.concatenate([owner, owner])[sel]]
        ok = k >= 0
        k, c, f = k[ok], cols[ok], coef[sel][ok]
        for i in range(3):
            a_eq[3 * k + i, c] = f[:, i]
    m = geo.mass[movers]
    b_eq = np.zeros(3 * len(movers))
    b_eq[0::3], b_eq[1::3] = -m * g[0], -m * g[1]
    return a_eq, b_eq, m


def _blame(a_eq, b_eq, m, movers: list[str]) -> list[str]:
    """The parts with slack in the least-slack elastic program (slack per unit of weight)."""
    rows = a_eq.shape[0]
    weight = np.repeat(m, 3)
    a_el = np.hstack([a_eq, np.diag(weight), -np.diag(weight)])
    c = np.concatenate([np.zeros(a_eq.shape[1]), np.ones(2 * rows)])
    x = solve_lp(a_el, b_eq, c).x
    if x is None:
        return []
    s = x[a_eq.shape[1]:]
    slack = (s[:rows] + s[rows:]).reshape(-1, 3).sum(axis=1)
    return [p for p, v in zip(movers, slack) if v > _BLAME_SLACK]


def _mechanism_reason(geo: _Geometry, loads: _Loads, present: np.ndarray, movers: np.ndarray,
                      mu: float) -> str:
    """A reason when one part alone tips or slides with the others fixed
    (``rap.sim.mechanisms``), else ''."""
    found = first_mechanism(loads.mechanisms, movers, present[geo.partner[movers]])
    if found is None:
        return ""
    part, found = geo.ids[movers[found[0]]], found[1]
    if found.kind == "tip":
        x, y = (geo.center[i] + geo.size * found.where[i] for i in (0, 1))
        return f"part {part!r} would tip over about ({x:.4g}, {y:.4g})"
    dx, dy = (v + 0.0 for v in found.where)  # + 0.0: no "-0" in the message
    return f"part {part!r} would {found.kind} along ({dx:.3g}, {dy:.3g}) with friction {mu:g}"


def _loads(assembly: Assembly, g: tuple[float, float], mu: float, margin: float) -> _Loads:
    geo = _geometry(assembly, margin)
    return _memo(_LOADS, (assembly.geometry_hash, margin, g, mu), lambda: _build_loads(geo, g, mu))


def _masks(geo: _Geometry, chosen: Iterable[str], base: str):
    """The parts ``chosen`` as a bool mask over rows (one more entry: padding, never present),
    the other parts' rows sorted by id, and their ids."""
    present = np.zeros(len(geo.ids) + 1, dtype=bool)
    present[[geo.row[p] for p in chosen]] = True
    names = sorted(set(chosen) - {base})
    return present, np.array([geo.row[p] for p in names], dtype=np.intp), names


def _solve(assembly: Assembly, chosen: frozenset, base: str, g: tuple[float, float],
           mu: float, margin: float) -> Support:
    if len(chosen) == 1:
        return Support(True)
    geo = _geometry(assembly, margin)
    reason = _connectivity_reason(geo, [geo.row[p] for p in chosen], geo.row[base])
    if reason:
        return Support(False, reason)
    present, movers, names = _masks(geo, chosen, base)
    loads = _loads(assembly, g, mu, margin)
    reason = _mechanism_reason(geo, loads, present, movers, mu)
    if reason:
        return Support(False, reason)
    a_eq, b_eq, m = _system(geo, loads, present, movers, g)
    status = solve_lp(a_eq, b_eq, np.zeros(a_eq.shape[1])).status
    if status == "optimal":
        return Support(True)
    if status != "infeasible":  # HiGHS gave up (numerical trouble): not shown stable
        return Support(False, f"{_names(names)}: the equilibrium program failed (HiGHS: "
                              f"{status})")
    named = _blame(a_eq, b_eq, m, names) or names
    one = len(named) == 1
    return Support(False, f"{_names(named)} {'has' if one else 'have'} no equilibrium under "
                          f"gravity with friction {mu:g}: {'it' if one else 'they'} would slide "
                          f"or tip")


def check_support_args(assembly: Assembly, chosen, base: str, gravity: tuple[float, float],
                       friction: float) -> tuple[float, float, float]:
    """(gx, gy, |g|) as floats after checking the arguments of a support question (``check_static``,
    ``rap.sim.settling.settle``): ``ValueError`` when ``base`` is not in ``chosen``, gravity is zero
    or not finite, or friction negative or not finite; ``KeyError`` for an unknown part id."""
    if base not in chosen:
        raise ValueError(f"the base part {base!r} is not among the parts")
    for pid in chosen:
        assembly.index(pid)
    gx, gy = float(gravity[0]), float(gravity[1])
    norm = math.hypot(gx, gy)
    if not (math.isfinite(norm) and norm > 0):
        raise ValueError(f"gravity must be a nonzero finite direction, not {tuple(gravity)}")
    mu = float(friction)
    if not (math.isfinite(mu) and mu >= 0):
        raise ValueError(f"friction must be a finite number >= 0, not {friction}")
    return gx, gy, norm


def check_static(assembly: Assembly, ids: Iterable[str], base: str,
                 gravity: tuple[float, float], friction: float = DEFAULT_FRICTION,
                 margin: float = DEFAULT_MARGIN) -> Support:
    """Is there an equilibrium of the parts ``ids`` standing on the fixed part ``base`` under
    ``gravity`` with Coulomb friction coefficient ``friction``, the contact segments shortened by
    ``margin`` of their length at each end? (See the module doc for the model, the margin, the
    reasons and the cost.) ``ValueError`` when ``base`` is not in ``ids``, gravity is zero or not
    finite, friction is negative or margin outside [0, 0.5); ``KeyError`` for an unknown part
    id."""
    chosen = frozenset(ids)
    gx, gy, norm = check_support_args(assembly, chosen, base, gravity, friction)
    mu = float(friction)
    margin = float(margin)
    if not (0 <= margin < 0.5):
        raise ValueError(f"margin must be in [0, 0.5), not {margin}")
    key = (assembly.geometry_hash, chosen, base, gx, gy, mu, margin)
    with _LOCK:
        hit = _RESULTS.get(key)
        if hit is not None:
            _RESULTS.move_to_end(key)
            return hit
    result = _solve(assembly, chosen, base, (gx / norm, gy / norm), mu, margin)
    with _LOCK:
        _RESULTS[key] = result
        while len(_RESULTS) > CACHE_SIZE:
            _RESULTS.popitem(last=False)
    return result


def clear_results() -> None:
    """Forget the memoised verdicts (the per-assembly tables stay): for timing first calls."""
    with _LOCK:
        _RESULTS.clear()
