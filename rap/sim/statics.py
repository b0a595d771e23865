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

Cost: the assembly's contact table and per-part data are built once per geometry hash (and
margin); a call then builds a dense (3 x parts) by (2 x contact points) matrix and solves one LP
with HiGHS (a second, elastic one only to name the parts when infeasible): a few milliseconds for
a subset of the 22-brick wall, most of it scipy's ``linprog`` wrapper (``benchmarks/statics.py``
prints the figures). Results are memoised per ``(geometry hash, frozenset(ids), base, gravity,
friction, margin)`` in a bounded LRU cache (``CACHE_SIZE`` entries); it is thread-safe.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Iterable

import numpy as np
from scipy.optimize import linprog

from rap.assembly import Assembly
from rap.geometry.contacts import contact_table, contacts_within
from rap.sim.mechanisms import part_mechanisms

__all__ = ["DEFAULT_FRICTION", "DEFAULT_MARGIN", "Support", "check_static", "CACHE_SIZE"]

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
    """Per-assembly data in normalised units (see the module doc)."""

    mass: dict  # part id -> mass (area / mean area)
    centroid: dict  # part id -> (x, y) normalised
    points: dict  # (a, b) -> float array [k, 4]: x, y, unit normal (a into b), normalised
    size: float  # the assembly's larger extent: one normalised length unit
    center: tuple[float, float]  # the origin of the normalised coordinates
    row: dict  # part id -> row of the arrays below
    own_points: np.ndarray  # [parts, K, 4]: each part's contact points, normals into it, padded
    partner: np.ndarray  # [parts, K]: the row of the part across each point (-1: padding)


def _centroid_area(part) -> tuple[float, float, float]:
    """Exact area and centroid of a part (holes included), returned as floats."""
    a2 = cx6 = cy6 = 0
    for ring in part.rings():
        n = len(ring)
        for i in range(n):
            (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
            c = x0 * y1 - x1 * y0
            a2 += c
            cx6 += (x0 + x1) * c
            cy6 += (y0 + y1) * c
    return float(a2 / 2), float(cx6 / (3 * a2)), float(cy6 / (3 * a2))


def _build(assembly: Assembly, margin: float) -> _Geometry:
    x0, y0, x1, y1 = assembly.bounds()
    size = max(x1 - x0, y1 - y0)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    data = {p.id: _centroid_area(p) for p in assembly.parts}
    mean_area = sum(a for a, _, _ in data.values()) / len(data)
    mass = {pid: a / mean_area for pid, (a, _, _) in data.items()}
    centroid = {pid: ((x - cx) / size, (y - cy) / size) for pid, (_, x, y) in data.items()}
    points = {}
    for pair, contacts in contact_table(assembly).items():
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
        points[pair] = np.array(rows, dtype=float).reshape(-1, 4)
    row = {pid: i for i, pid in enumerate(assembly.ids)}
    own: list[list[np.ndarray]] = [[] for _ in row]
    across: list[list[int]] = [[] for _ in row]
    for (a, b), pts in points.items():
        own[row[b]].append(pts)
        across[row[b]] += [row[a]] * len(pts)
        own[row[a]].append(np.concatenate([pts[:, :2], -pts[:, 2:]], axis=1))
        across[row[a]] += [row[b]] * len(pts)
    k = max([len(x) for x in across] + [1])
    own_points = np.zeros((len(row), k, 4))
    partner = np.full((len(row), k), -1, dtype=int)
    for i, blocks in enumerate(own):
        if blocks:
            own_points[i, :len(across[i])] = np.concatenate(blocks)
            partner[i, :len(across[i])] = across[i]
    return _Geometry(mass, centroid, points, size, (cx, cy), row, own_points, partner)


_GEOMETRY: OrderedDict[tuple, _Geometry] = OrderedDict()
_RESULTS: OrderedDict[tuple, Support] = OrderedDict()
_LOCK = threading.Lock()


def _geometry(assembly: Assembly, margin: float) -> _Geometry:
    key = (assembly.geometry_hash, margin)
    with _LOCK:
        hit = _GEOMETRY.get(key)
        if hit is not None:
            _GEOMETRY.move_to_end(key)
            return hit
    geo = _build(assembly, margin)
    with _LOCK:
        _GEOMETRY[key] = geo
        while len(_GEOMETRY) > 32:
            _GEOMETRY.popitem(last=False)
    return geo


def _names(parts: list[str]) -> str:
    quoted = ", ".join(repr(p) for p in parts[:5]) + (", ..." if len(parts) > 5 else "")
    return f"part {quoted}" if len(parts) == 1 else f"parts {quoted}"


def _connectivity_reason(chosen: set[str], base: str, pairs) -> str:
    """A reason when some part touches nothing or is cut off from the base, else ''."""
    links: dict[str, set[str]] = {p: set() for p in chosen}
    for a, b in pairs:
        links[a].add(b)
        links[b].add(a)
    alone = sorted(p for p in chosen if p != base and not links[p])
    if alone:
        return f"{_names(alone)} {'touches' if len(alone) == 1 else 'touch'} no other part"
    seen, todo = {base}, [base]
    while todo:
        for q in links[todo.pop()] - seen:
            seen.add(q)
            todo.append(q)
    cut = sorted(chosen - seen)
    if cut:
        return f"{_names(cut)} {'rests' if len(cut) == 1 else 'rest'} on nothing connected to " \
               f"the base {base!r}"
    return ""


def _system(geo: _Geometry, movers: list[str], pairs, g: tuple[float, float], mu: float):
    """A_eq, b_eq of the equilibrium of the parts ``movers`` (3 rows each)."""
    row = {p: i for i, p in enumerate(movers)}
    blocks = [geo.points[pair] for pair in pairs]
    owners = [(row.get(a, -1), row.get(b, -1)) for a, b in pairs]
    counts = [len(b) for b in blocks]
    pts = np.concatenate(blocks) if blocks else np.zeros((0, 4))
    ia = np.repeat([o[0] for o in owners], counts).astype(int)
    ib = np.repeat([o[1] for o in owners], counts).astype(int)
    n, t = pts[:, 2:4], np.stack([-pts[:, 3], pts[:, 2]], axis=1)
    rays = np.concatenate([n + mu * t, n - mu * t])  # [2k, 2]: force on b per unit weight
    xy = np.concatenate([pts[:, :2], pts[:, :2]])
    ia, ib = np.concatenate([ia, ia]), np.concatenate([ib, ib])
    cols = np.arange(len(rays))
    a_eq = np.zeros((3 * len(movers), len(rays)))
    cen = np.array([geo.centroid[p] for p in movers]).reshape(-1, 2)
    for owner, sign in ((ib, 1.0), (ia, -1.0)):
        ok = owner >= 0
        k, c, f = owner[ok], cols[ok], sign * rays[ok]
        r = xy[ok] - cen[k]
        a_eq[3 * k, c] = f[:, 0]
        a_eq[3 * k + 1, c] = f[:, 1]
        a_eq[3 * k + 2, c] = r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]
    m = np.array([geo.mass[p] for p in movers])
    b_eq = np.zeros(3 * len(movers))
    b_eq[0::3], b_eq[1::3] = -m * g[0], -m * g[1]
    return a_eq, b_eq, m


def _mechanism_reason(geo: _Geometry, chosen: set[str], movers: list[str],
                      g: tuple[float, float], mu: float) -> str:
    """A reason when one part alone tips or slides with the others fixed
    (``rap.sim.mechanisms``), else ''."""
    rows = [geo.row[p] for p in movers]
    present = np.zeros(len(geo.row) + 1, dtype=bool)  # the last entry: padding (-1)
    present[[geo.row[p] for p in chosen]] = True
    pts, partner = geo.own_points[rows], geo.partner[rows]
    found_all = part_mechanisms(pts[..., :2], pts[..., 2:], present[partner],
                                np.array([geo.centroid[p] for p in movers]), np.array(g), mu)
    for part, found in zip(movers, found_all):
        if found is None:
            continue
        if found.kind == "tip":
            x, y = (geo.center[i] + geo.size * found.where[i] for i in (0, 1))
            return f"part {part!r} would tip over about ({x:.4g}, {y:.4g})"
        dx, dy = (v + 0.0 for v in found.where)  # + 0.0: no "-0" in the message
        return (f"part {part!r} would {found.kind} along ({dx:.3g}, {dy:.3g}) with friction "
                f"{mu:g}")
    return ""


def _blame(a_eq, b_eq, m, movers: list[str]) -> list[str]:
    """The parts with slack in the least-slack elastic program (slack per unit of weight)."""
    rows = a_eq.shape[0]
    weight = np.repeat(m, 3)
    a_el = np.hstack([a_eq, np.diag(weight), -np.diag(weight)])
    c = np.concatenate([np.zeros(a_eq.shape[1]), np.ones(2 * rows)])
    res = linprog(c, A_eq=a_el, b_eq=b_eq, bounds=(0, None), method="highs")
    if res.status != 0:
        return []
    s = res.x[a_eq.shape[1]:]
    slack = (s[:rows] + s[rows:]).reshape(-1, 3).sum(axis=1)
    return [p for p, v in zip(movers, slack) if v > _BLAME_SLACK]


def _solve(assembly: Assembly, chosen: set[str], base: str, g: tuple[float, float],
           mu: float, margin: float) -> Support:
    movers = sorted(chosen - {base})
    if not movers:
        return Support(True)
    pairs = sorted(contacts_within(assembly, chosen))
    reason = _connectivity_reason(chosen, base, pairs)
    if reason:
        return Support(False, reason)
    geo = _geometry(assembly, margin)
    reason = _mechanism_reason(geo, chosen, movers, g, mu)
    if reason:
        return Support(False, reason)
    a_eq, b_eq, m = _system(geo, movers, pairs, g, mu)
    res = linprog(np.zeros(a_eq.shape[1]), A_eq=a_eq, b_eq=b_eq, bounds=(0, None),
                  method="highs")
    if res.status == 0:
        return Support(True)
    if res.status != 2:  # HiGHS gave up (numerical trouble): not shown stable
        return Support(False, f"{_names(movers)}: the equilibrium program failed "
                              f"({res.message})")
    named = _blame(a_eq, b_eq, m, movers) or movers
    one = len(named) == 1
    return Support(False, f"{_names(named)} {'has' if one else 'have'} no equilibrium under "
                          f"gravity with friction {mu:g}: {'it' if one else 'they'} would slide "
                          f"or tip")


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
    margin = float(margin)
    if not (0 <= margin < 0.5):
        raise ValueError(f"margin must be in [0, 0.5), not {margin}")
    key = (assembly.geometry_hash, chosen, base, gx, gy, mu, margin)
    with _LOCK:
        hit = _RESULTS.get(key)
        if hit is not None:
            _RESULTS.move_to_end(key)
            return hit
    result = _solve(assembly, set(chosen), base, (gx / norm, gy / norm), mu, margin)
    with _LOCK:
        _RESULTS[key] = result
        while len(_RESULTS) > CACHE_SIZE:
            _RESULTS.popitem(last=False)
    return result
