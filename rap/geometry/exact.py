"""Exact integer kernel: scaling to integers, orientation, directions on the circle.

Every predicate here works on Python ``int`` (or ``Fraction``) values and is exact; there is no
epsilon. Directions are integer vectors ``(dx, dy) != (0, 0)``; two directions are *equal* when
they are positive multiples of each other (``primitive`` gives the canonical representative).
Angles are measured counter-clockwise (CCW) from angle 0, the +x axis, and compared with a
half-plane test plus a cross product (no ``atan2``). Floats appear only in ``unit`` and
``arc_middle_unit``, which produce unit vectors for output.

Open arcs ``(s, e)`` are the directions strictly between ``s`` and ``e`` going CCW from ``s``.
``s == e`` (as directions) denotes the whole circle minus that one direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from math import gcd, lcm
from typing import Sequence

from rap.assembly import Assembly

__all__ = [
    "IVec",
    "IntPart",
    "IntAssembly",
    "scale_factor",
    "to_integers",
    "cross",
    "dot",
    "orient",
    "bounding_box",
    "primitive",
    "same_direction",
    "half",
    "angle_key",
    "compare_angle",
    "in_open_arc",
    "arc_interior_vector",
    "arc_middle_unit",
    "unit",
    "exact_direction",
    "open_arc_middle",
]

IVec = tuple[int, int]


@dataclass(frozen=True)
class IntPart:
    """A part with integer coordinates: ``outer`` CCW, ``holes`` CW (as in ``rap.assembly.Part``)."""

    id: str
    outer: tuple[IVec, ...]
    holes: tuple[tuple[IVec, ...], ...] = ()

    def rings(self) -> tuple[tuple[IVec, ...], ...]:
        return (self.outer, *self.holes)


@dataclass(frozen=True)
class IntAssembly:
    """An assembly scaled by the positive integer ``scale``: every coordinate times ``scale``."""

    name: str
    source: str
    scale: int
    parts: tuple[IntPart, ...]

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(p.id for p in self.parts)


def scale_factor(assembly: Assembly) -> int:
    """LCM of the denominators of every coordinate (1 for integer input). O(total vertices)."""
    den = 1
    for p in assembly.parts:
        for ring in p.rings():
            for x, y in ring:
                den = lcm(den, Fraction(x).denominator, Fraction(y).denominator)
    return den


def to_integers(assembly: Assembly) -> IntAssembly:
    """Scale every coordinate by ``scale_factor`` (exact; a positive scale keeps directions)."""
    s = scale_factor(assembly)

    def ring(r):
        return tuple((int(x * s), int(y * s)) for x, y in r)

    parts = tuple(IntPart(p.id, ring(p.outer), tuple(ring(h) for h in p.holes))
                  for p in assembly.parts)
    return IntAssembly(assembly.name, assembly.source, s, parts)


def cross(ax, ay, bx, by):
    """z-component of (ax, ay) x (bx, by)."""
    return ax * by - ay * bx


def dot(ax, ay, bx, by):
    return ax * bx + ay * by


def bounding_box(points: Sequence[Sequence]) -> tuple:
    """``(min x, min y, max x, max y)`` of a non-empty sequence of points, in their own number
    type (exact for integers and fractions). O(len(points))."""
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    return min(xs), min(ys), max(xs), max(ys)


def orient(p: Sequence, q: Sequence, r: Sequence):
    """Twice the signed area of triangle pqr: > 0 left turn (CCW), < 0 right turn, 0 collinear."""
    return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])


def primitive(d: Sequence[int]) -> IVec:
    """Canonical representative of an integer direction: divided by the gcd of its coordinates."""
    x, y = int(d[0]), int(d[1])
    g = gcd(x, y)
    if g == 0:
        raise ValueError("the zero vector has no direction")
    return (x // g, y // g)


def same_direction(u: Sequence, v: Sequence) -> bool:
    """True when u and v are positive multiples of each other."""
    return u[0] * v[1] - u[1] * v[0] == 0 and u[0] * v[0] + u[1] * v[1] > 0


def half(d: Sequence) -> int:
    """0 for angles in [0, pi), 1 for angles in [pi, 2 pi)."""
    x, y = d[0], d[1]
    return 0 if (y > 0 or (y == 0 and x > 0)) else 1


class _Slope:
    """An exact ratio ``num / den`` (``den > 0``) compared by cross multiplication: the exact
    part of ``angle_key``, read only where two correctly rounded float ratios are equal."""

    __slots__ = ("num", "den")

    def __init__(self, num, den):
        self.num, self.den = num, den

    def __eq__(self, other):
        return self.num * other.den == other.num * self.den

    def __lt__(self, other):
        return self.num * other.den < other.num * self.den

    def __le__(self, other):
        return self.num * other.den <= other.num * self.den

    def __gt__(self, other):
        return self.num * other.den > other.num * self.den

    def __ge__(self, other):
        return self.num * other.den >= other.num * self.den

    def __hash__(self):
        return hash(Fraction(self.num) / Fraction(self.den))


def _ratio(num, den) -> float:
    """``num / den`` correctly rounded (monotone in the exact ratio): Python's int division is
    correctly rounded, and so is a Fraction's conversion."""
    if isinstance(num, int) and isinstance(den, int):
        return num / den
    return float(Fraction(num) / Fraction(den))


def angle_key(d: Sequence) -> tuple[int, float, _Slope]:
    """A sort key increasing with the CCW angle of d in [0, 2 pi); equal for equal directions.

    Quadrant index plus a ratio that is monotone inside the quadrant, exact: the ratio correctly
    rounded to a float (monotone, so it orders all but float ties, in C) and then the exact ratio
    (compared by cross multiplication, only on a tie).
    """
    x, y = d[0], d[1]
    if x > 0 and y >= 0:
        return (0, _ratio(y, x), _Slope(y, x))
    if x <= 0 and y > 0:
        return (1, _ratio(-x, y), _Slope(-x, y))
    if x < 0 and y <= 0:
        return (2, _ratio(-y, -x), _Slope(-y, -x))
    if x >= 0 and y < 0:
        return (3, _ratio(x, -y), _Slope(x, -y))
    raise ValueError("the zero vector has no direction")


def compare_angle(u: Sequence, v: Sequence) -> int:
    """-1, 0, 1 as the CCW angle of u from +x is less than, equal to, greater than v's."""
    hu, hv = half(u), half(v)
    if hu != hv:
        return -1 if hu < hv else 1
    c = u[0] * v[1] - u[1] * v[0]
    return -1 if c > 0 else (1 if c < 0 else 0)


def in_open_arc(d: Sequence, s: Sequence, e: Sequence) -> bool:
    """Is direction d strictly inside the open CCW arc from s to e? (s == e: circle minus s.)"""
    cse = s[0] * e[1] - s[1] * e[0]
    if cse > 0:  # arc < 180 degrees
        return s[0] * d[1] - s[1] * d[0] > 0 and d[0] * e[1] - d[1] * e[0] > 0
    if cse == 0:
        if s[0] * e[0] + s[1] * e[1] > 0:  # same direction: circle minus s
            return not same_direction(d, s)
        return s[0] * d[1] - s[1] * d[0] > 0  # exactly 180 degrees: open half-plane left of s
    # arc > 180: d is inside unless it lies in the closed complement arc [e, s] (< 180)
    return not (e[0] * d[1] - e[1] * d[0] >= 0 and d[0] * s[1] - d[1] * s[0] >= 0)


def arc_interior_vector(s: Sequence[int] | None, e: Sequence[int] | None) -> IVec:
    """An exact primitive integer direction strictly inside the open arc (s, e).

    ``s is None`` (or ``e is None``) means the full circle: (1, 0) is returned.
    For arcs < 180 degrees: s/|s|_1 + e/|e|_1 with denominators cleared; exactly 180: s turned
    left by 90 degrees; > 180: the negated interior vector of the complement arc (e, s);
    s == e (circle minus s): -s.
    """
    if s is None or e is None:
        return (1, 0)
    sx, sy, ex, ey = int(s[0]), int(s[1]), int(e[0]), int(e[1])
    c = sx * ey - sy * ex
    if c > 0:
        ls, le = abs(sx) + abs(sy), abs(ex) + abs(ey)
        return primitive((sx * le + ex * ls, sy * le + ey * ls))
    if c == 0:
        if sx * ex + sy * ey > 0:
            return primitive((-sx, -sy))
        return primitive((-sy, sx))
    mx, my = arc_interior_vector((ex, ey), (sx, sy))
    return (-mx, -my)


def unit(d: Sequence) -> tuple[float, float]:
    """Float unit vector of a nonzero exact vector (ints or Fractions)."""
    try:
        x, y = float(d[0]), float(d[1])
        n = math.hypot(x, y)
    except OverflowError:
        n = math.inf
    if n == 0.0 or not math.isfinite(n):  # huge or tiny exact values: normalise exactly first
        g = max(abs(Fraction(d[0])), abs(Fraction(d[1])))
        x, y = float(Fraction(d[0]) / g), float(Fraction(d[1]) / g)
        n = math.hypot(x, y)
    return (x / n, y / n)


def _angle(d: Sequence) -> float:
    ux, uy = unit(d)
    a = math.atan2(uy, ux)
    return a + 2 * math.pi if a < 0 else a


def arc_middle_unit(s: Sequence | None, e: Sequence | None) -> tuple[float, float]:
    """Float unit vector at the angular middle of the open arc (s, e) (floats: output only).

    The full circle (``None``) gives (1, 0); s == e (circle minus s) gives -s.
    """
    if s is None or e is None:
        return (1.0, 0.0)
    a, b = _angle(s), _angle(e)
    span = (b - a) % (2 * math.pi)
    if same_direction(s, e):
        span = 2 * math.pi
    m = a + span / 2
    return (math.cos(m), math.sin(m))


def exact_direction(d: Sequence) -> IVec:
    """Primitive integer direction of a vector given as ints, Fractions or finite floats."""
    fx, fy = Fraction(d[0]), Fraction(d[1])
    den = lcm(fx.denominator, fy.denominator)
    return primitive((int(fx * den), int(fy * den)))


def open_arc_middle(s: Sequence[int], e: Sequence[int]) -> tuple[IVec, tuple[float, float]]:
    """(exact primitive direction, its float unit vector) strictly inside the open arc (s, e)
    (counter-clockwise from s to e; s == e: the circle minus s), at its angular middle: the exact
    bisector when s and e have equal length, else ``arc_middle_unit`` read exactly, replaced by
    ``arc_interior_vector`` where floats fall outside a tiny arc. O(1) big-int operations."""
    c = s[0] * e[1] - s[1] * e[0]
    if s[0] * s[0] + s[1] * s[1] == e[0] * e[0] + e[1] * e[1] and c != 0:
        # equal lengths: the exact bisector s + e (negated for arcs over 180 degrees)
        d = primitive((s[0] + e[0], s[1] + e[1]) if c > 0 else (-s[0] - e[0], -s[1] - e[1]))
        u = unit(d)
    else:
        u = arc_middle_unit(s, e)
        d = exact_direction(u)
    if not in_open_arc(d, s, e):  # floats fell outside a tiny arc: use an exact interior vector
        d = arc_interior_vector(s, e)
        u = unit(d)
    return d, u
