"""Building blocks of the parametric assembly families: options, the ``Family`` spec, exact rings.

* ``Option``: one family option (int or choice), its default and allowed range. A default of
  ``None`` means *drawn per seed*: uniformly from the range (or the choices), so the corpus varies
  it; an explicit value fixes it. ``parse`` reads a command-line string, ``check`` validates a
  value; both raise ``rap.errors.ParameterError`` naming the option (``rows 0: must be between 1
  and 20``; ``rap-farm generate`` shows ``wall: --rows 0: ...``).
* ``Family``: name, one-line description, options, and ``build(rng, opts) -> [Part]`` over resolved
  options (``problem(opts)``: None, or the option and why the combination cannot be built).
  ``Family.make(rng, **options)`` resolves the options (drawn ones are redrawn, at most
  ``REDRAWS`` times, until the part count is within ``DEFAULT_PARTS``; explicit ones never change),
  builds the parts and verifies the result exactly (``verify``): ``validate_assembly`` and a full
  decomposition over online NDBG partitions (``rap.geometry.andor.decomposition``). A failed verification is a
  bug in the family and raises ``FamilyError``.
  ``training`` False marks a held-out shape kind (``rap.geometry.families.unseen``): generated
  like the others, never labelled into the corpus nor selected for training.
* Exact rings: ``make_part(id, points)`` orients a ring counter-clockwise and drops repeated and
  collinear vertices; ``edge_points`` puts a knob (or its socket) on a straight edge between two
  integer points, in the edge's own integer frame (primitive direction and its left normal), so
  every vertex stays an integer point on slanted edges too.

Knob profiles are *half-profiles*: ``[(u0, 0), (u1, v1), ...]``, u the half-width and v the height
above the edge, half-widths non-increasing with height (no dovetails: a knob leaves its socket by
translating along the edge normal). ``socket_profile(half, c)`` is the socket with clearance c: each
point moves by (c, c) outward (base points by (c, 0), points on the axis by (0, c)), which leaves a
gap of at least c measured along the edge everywhere around a non-increasing profile.

Preconditions: integer inputs. Cost: O(vertices) per ring; verification is dominated by the NDBG
(about O(n^2) for n parts of bounded size).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from itertools import product
from typing import Callable, Sequence

import numpy as np

from rap.assembly import Assembly, Part
from rap.errors import InputError, ParameterError

__all__ = ["Option", "Family", "FamilyError", "DEFAULT_PARTS", "REDRAWS", "make_part", "ring_points",
           "edge_points", "shared_edge", "CONVEX_THEOREM_PARTS", "socket_profile", "mirror_profile", "verify", "IPoint"]

IPoint = tuple[int, int]
DEFAULT_PARTS = (4, 16)  # part counts of the corpus; drawn options are redrawn to stay inside
REDRAWS = 64
CONVEX_THEOREM_PARTS = 64  # above: convex parts are not searched (see ``verify``)


class FamilyError(RuntimeError):
    """A generated assembly failed its exact verification (a bug in the family, not bad input)."""


@dataclass(frozen=True)
class Option:
    """A family option: an int in [low, high] or one of ``choices``; ``default`` None: per seed."""

    name: str
    help: str
    low: int | None = None
    high: int | None = None
    choices: tuple[str, ...] | None = None
    default: int | str | None = None
    draw_low: int | None = None  # range drawn when the value is not given (default: low..high)
    draw_high: int | None = None

    @property
    def kind(self) -> str:
        return "choice" if self.choices else "int"

    @property
    def drawn(self) -> tuple:
        """The values a drawn option takes (in order)."""
        if self.choices:
            return self.choices
        return tuple(range(self.draw_low if self.draw_low is not None else self.low,
                           (self.draw_high if self.draw_high is not None else self.high) + 1))

    def describe(self) -> str:
        """``name=range (default)``, e.g. ``rows=1..40 (random 2..4)``."""
        allowed = "|".join(self.choices) if self.choices else f"{self.low}..{self.high}"
        if self.default is not None:
            return f"{self.name}={allowed} ({self.default})"
        d = self.drawn
        if self.choices and d == self.choices:
            return f"{self.name}={allowed} (random)"
        rnd = "|".join(d) if self.choices else f"{d[0]}..{d[-1]}"
        return f"{self.name}={allowed} (random {rnd})"

    def check(self, value):
        """The validated value; raises ``ParameterError`` naming the option."""
        if self.choices:
            if value not in self.choices:
                raise ParameterError(self.name, value, f"choose one of {', '.join(self.choices)}")
            return value
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ParameterError(self.name, value, "must be an integer")
        if not self.low <= value <= self.high:
            raise ParameterError(self.name, value, f"must be between {self.low} and {self.high}")
        return int(value)

    def parse(self, text: str):
        """Read a command-line value (validated)."""
        if self.choices:
            return self.check(text)
        try:
            value = int(text)
        except ValueError:
            raise ParameterError(self.name, text, "must be an integer") from None
        return self.check(value)

    def draw(self, rng: np.random.Generator):
        d = self.drawn
        return d[int(rng.integers(len(d)))]


@dataclass(frozen=True)
class Family:
    """A parametric family of assemblies (see the module docstring)."""

    name: str
    description: str
    options: tuple[Option, ...]
    build: Callable[[np.random.Generator, dict], Sequence[Part]] = field(repr=False)
    count: Callable[[dict], int] = field(repr=False)  # exact part count of resolved options
    count_options: tuple[str, ...] = ()  # the options ``count`` depends on
    problem: Callable[[dict], tuple[str, str] | None] = field(default=lambda o: None, repr=False)
    # ``problem(opts)``: (option, why) resolved options cannot be built together (None: they can)
    training: bool = True  # False: a held-out shape kind, never in a corpus or a training set

    def option(self, name: str) -> Option:
        for o in self.options:
            if o.name == name:
                return o
        raise InputError(f"{self.name}: no option {name!r} (options: "
                         f"{', '.join(o.name for o in self.options) or 'none'})")

    def check_options(self, options: dict) -> dict:
        """Validated explicit options (None values are left out: drawn)."""
        return {k: self.option(k).check(v) for k, v in options.items() if v is not None}

    def resolve(self, rng: np.random.Generator, **options) -> dict:
        """Every option's value: explicit ones validated, the others drawn from ``rng`` (in option
        order). Drawn values are redrawn (at most ``REDRAWS`` times) while ``problem`` objects to
        the combination or the part count is outside ``DEFAULT_PARTS``; ``ParameterError`` (the
        option ``problem`` names) when no draw suits the explicit options."""
        given = self.check_options(options)
        best, best_miss, why, refused = None, None, None, {}
        for _ in range(REDRAWS):
            opts = {}
            for o in self.options:
                if o.name in given:
                    opts[o.name] = given[o.name]
                elif o.default is not None:
                    opts[o.name] = o.default
                else:
                    opts[o.name] = o.draw(rng)
            why = self.problem(opts)
            if why is not None:
                refused = opts
                continue
            n = self.count(opts)
            miss = max(DEFAULT_PARTS[0] - n, n - DEFAULT_PARTS[1], 0)
            if miss == 0:
                return opts
            if best_miss is None or miss < best_miss:
                best, best_miss = opts, miss
        if best is None:
            name, reason = why
            raise ParameterError(name, refused[name], reason)
        return best

    def part_range(self, **options) -> tuple[int, int]:
        """(min, max) part count over the drawn values of the count options, given the explicit
        ones (combinations outside ``DEFAULT_PARTS`` are redrawn, so they count only when no
        combination fits)."""
        given = self.check_options(options)
        free = [self.option(k) for k in self.count_options if k not in given]
        counts = []
        for values in product(*[o.drawn if o.default is None else (o.default,) for o in free]):
            counts.append(self.count({**given, **dict(zip((o.name for o in free), values))}))
        inside = [n for n in counts if DEFAULT_PARTS[0] <= n <= DEFAULT_PARTS[1]]
        pool = inside or counts
        return min(pool), max(pool)

    def make(self, rng: np.random.Generator, name: str | None = None, **options) -> Assembly:
        """A verified assembly of this family (options as in ``resolve``)."""
        return self.build_resolved(rng, self.resolve(rng, **options), name)

    def build_resolved(self, rng: np.random.Generator, opts: dict, name: str | None = None) -> Assembly:
        asm = Assembly(name or self.name, tuple(self.build(rng, opts)), family=self.name)
        if len(asm) != self.count(opts):
            raise FamilyError(f"{self.name}: built {len(asm)} parts, expected {self.count(opts)}")
        verify(asm)
        return asm


def _convex_parts(asm: Assembly) -> bool:
    """Is every part a convex polygon without holes? (exact; rings have no collinear vertices)"""
    for p in asm.parts:
        ring = p.outer
        if p.holes:
            return False
        for i in range(len(ring)):
            a, b, c = ring[i - 1], ring[i], ring[(i + 1) % len(ring)]
            if (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]) <= 0:
                return False
    return True


def verify(asm: Assembly) -> None:
    """Raise ``FamilyError`` unless the assembly has integer vertices, is valid and is not
    interlocked: ``decomposition`` finds a full decomposition over online NDBG partitions.

    Above ``CONVEX_THEOREM_PARTS`` parts, an assembly of convex parts without holes is accepted
    without the search (n - 1 partition queries, minutes at 400 parts): by Guibas and Yao's
    theorem every direction's blocking graph of convex parts is acyclic, so every subassembly
    has an online partition.
    """
    from rap.assembly import AssemblyError
    from rap.geometry.andor import decomposition
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.validation import validate_assembly

    for p in asm.parts:
        for ring in p.rings():
            if any(x.denominator != 1 or y.denominator != 1 for x, y in ring):
                raise FamilyError(f"{asm.name}: part {p.id!r} has a non-integer vertex")
    try:
        validate_assembly(asm)
    except AssemblyError as exc:
        raise FamilyError(f"{asm.name}: invalid: {exc}") from None
    if len(asm) > CONVEX_THEOREM_PARTS and _convex_parts(asm):
        return
    if decomposition(build_ndbg(asm)) is None:
        raise FamilyError(f"{asm.name}: interlocked (no full decomposition)")


# -- exact rings ------------------------------------------------------------------------------
def ring_points(points: Sequence[Sequence[int]]) -> list[IPoint]:
    """Integer ring without repeated, closing or collinear vertices, counter-clockwise."""
    pts: list[IPoint] = []
    for x, y in points:
        p = (int(x), int(y))
        if not pts or pts[-1] != p:
            pts.append(p)
    while len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
    changed = True
    while changed and len(pts) >= 3:  # drop collinear vertices (straight and folded-back ones)
        changed = False
        n = len(pts)
        for i in range(n):
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % n]
            if (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]) == 0:
                del pts[i]
                changed = True
                break
    area2 = sum(pts[i - 1][0] * pts[i][1] - pts[i][0] * pts[i - 1][1] for i in range(len(pts)))
    if area2 < 0:
        pts.reverse()
    return pts


def make_part(pid: str, points: Sequence[Sequence[int]]) -> Part:
    """A ``Part`` with exact integer coordinates (``Fraction``), outer ring counter-clockwise."""
    return Part(pid, tuple((Fraction(x), Fraction(y)) for x, y in ring_points(points)))


def mirror_profile(half: Sequence[tuple[int, int]]) -> list[tuple[int, int]]:
    """Full knob outline from the left base point to the right base point (u, v) of a
    half-profile (points on the axis u = 0 appear once)."""
    left = [(-u, v) for u, v in half]
    right = [(u, v) for u, v in reversed(half) if u != 0]
    return left + right


def socket_profile(half: Sequence[tuple[int, int]], clearance: int) -> list[tuple[int, int]]:
    """The socket of a non-increasing half-profile with clearance c (module docstring)."""
    c = clearance
    return [(u + c if u else 0, v + c if v else 0) for u, v in half]


def edge_points(a: IPoint, b: IPoint, half: Sequence[tuple[int, int]] | None = None,
                at: int | None = None, side: int = 1) -> list[IPoint]:
    """Points from a to b (both included) along the straight edge ab with a knob outline.

    The edge's frame is e = primitive(b - a) and n = (-e_y, e_x) (its left normal); ``half`` is a
    half-profile in units of e and n, centred ``at`` units of e from a (default: the middle,
    rounded down), protruding to the left of a -> b when ``side`` is 1, to the right when -1.
    """
    from math import gcd

    dx, dy = b[0] - a[0], b[1] - a[1]
    g = gcd(dx, dy)
    if g == 0:
        raise ValueError("degenerate edge")
    ex, ey = dx // g, dy // g
    nx, ny = -ey * side, ex * side
    if half is None:
        return [a, b]
    at = g // 2 if at is None else at
    pts = [a]
    for u, v in mirror_profile(half):
        s = at + u
        if not 0 < s < g and v == 0:
            raise ValueError("knob base does not fit on the edge")
        pts.append((a[0] + s * ex + v * nx, a[1] + s * ey + v * ny))
    pts.append(b)
    return pts


def shared_edge(a: IPoint, b: IPoint, half: Sequence[tuple[int, int]] | None, at: int | None = None,
                side: int = 1, clearance: int = 0) -> tuple[list[IPoint], list[IPoint]]:
    """The two sides of a keyed edge a -> b: (the left part's polyline a -> b, the right part's
    b -> a). The knob protrudes to ``side`` (1: into the left part, -1: into the right one) and
    belongs to the part on the other side; the part it protrudes into gets the socket with
    ``clearance``. Each part's boundary, counter-clockwise, uses its polyline as given."""
    if half is None:
        return [a, b], [b, a]
    knob = edge_points(a, b, half, at, side)
    sock = edge_points(a, b, socket_profile(half, clearance), at, side)
    if side == 1:
        return sock, knob[::-1]
    return knob, sock[::-1]
