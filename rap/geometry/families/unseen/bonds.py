"""Interlocking brick bonds: English and Flemish bond courses keyed to each other (``bond``).

The elevation of a wall ``courses`` courses high on a footing (``base``). Units: a header is ``u``
long, a stretcher ``2u``, a closer ``u / 2``. ``english``: stretcher courses and header courses
alternate (a header course starts and ends with a closer, so its joints fall over the middle of
the stretchers). ``flemish``: every course alternates stretchers and headers, each course shifted
by a header and a half so that a header sits over the middle of the stretcher below. A course is
cut to the wall's length; a brick left shorter than a closer joins its neighbour.

Interlocking courses: every brick (but a closer too short for one) has one stud on top (a rectangle, or a trapezoid narrowing
upward; never an undercut) in a socket of the brick above it, placed where no head joint of the
course above falls within its reach, and the footing keys every brick of the first course the same
way; a socket fits its stud exactly or with one unit of clearance (drawn per stud). Head joints
are straight, so a course's bricks slide past each other vertically.

Not interlocked: the top course leaves upward brick by brick, then the next (``verify`` checks it
exactly). Parts: 1 + the bricks (8, 10 or 11 with the default options). Cost: O(parts).
Held out of training (``Family.training`` False).
"""

from __future__ import annotations

import numpy as np

from rap.geometry.families.base import Family, Option, make_part

__all__ = ["BOND"]


def _course(pattern: list[int], start: int, length: int, closer: int) -> list[tuple[int, int]]:
    """Bricks (x0, x1) of a course: ``pattern``'s lengths repeated from ``start`` (<= 0), cut to
    [0, length]; a brick shorter than ``closer`` joins its neighbour."""
    out, x, i = [], start, 0
    while x < length:
        x1 = x + pattern[i % len(pattern)]
        a, b = max(x, 0), min(x1, length)
        if b > a:
            out.append([a, b])
        x, i = x1, i + 1
    if len(out) > 1 and out[0][1] - out[0][0] < closer:
        out[1][0] = out.pop(0)[0]
    if len(out) > 1 and out[-1][1] - out[-1][0] < closer:
        out[-2][1] = out.pop()[1]
    return [(a, b) for a, b in out]


def _courses(o: dict, u: int) -> list[list[tuple[int, int]]]:
    n, q = o["stretchers"], u // 2
    length = 2 * u * n
    out = []
    for k in range(o["courses"]):
        if o["bond"] == "english":
            out.append(_course([2 * u], 0, length, q) if k % 2 == 0
                       else [(0, q)] + _course([u], q, length - q, q) + [(length - q, length)])
        else:
            out.append(_course([2 * u, u], 0 if k % 2 == 0 else -(u + q), length, q))
    return out


def _count(o: dict) -> int:
    return 1 + sum(len(c) for c in _courses(o, 8))


def _studs(rng, below: list[tuple[int, int]], above_joints: set[int], w: int, reach: int) -> list:
    """The centre of one stud per brick of ``below`` where there is room: its socket (half-width
    up to ``w + reach - 1``) clear of ``above_joints`` by a unit, the stud clear of the brick's
    ends by 2."""
    out = []
    for x0, x1 in below:
        ok = [x for x in range(x0 + w + 2, x1 - w - 1)
              if all(abs(x - j) > w + reach for j in above_joints)]
        if ok:  # a closer may have no room: it is held by its neighbours' keys alone
            out.append(ok[int(rng.integers(len(ok)))])
    return out


def _bond(rng: np.random.Generator, o: dict) -> list:
    u = 2 * int(rng.integers(6, 9))  # even: closers are u / 2
    h = int(rng.integers(6, 11))
    courses = _courses(o, u)
    length = courses[0][-1][1]
    w, d = int(rng.integers(1, 3)), int(rng.integers(2, 4))  # stud half-width at its root, height
    taper = int(rng.integers(0, 2))
    # keys[k]: the studs under course k, (centre, socket clearance): one per brick below it
    # (course 0: per brick of its own, on the footing), clear of course k's head joints
    keys = []
    for k, course in enumerate(courses):
        joints = {a for a, _ in course} | {b for _, b in course}
        lower = course if k == 0 else courses[k - 1]
        keys.append([(x, int(rng.integers(0, 2))) for x in _studs(rng, lower, joints, w, 2)])

    def stud(x, c, y):  # left to right: a stud (c = 0) or its socket (clearance c) up from y
        return [(x - w - c, y), (x - w + taper - c, y + d + c), (x + w - taper + c, y + d + c),
                (x + w + c, y)]

    def studs_top(keyed, x0, x1, y):  # right to left along a top edge (x1 -> x0)
        pts = []
        for x, _ in reversed(keyed):
            if x0 < x < x1:
                pts += stud(x, 0, y)[::-1]
        return pts

    base_h = int(rng.integers(4, 8))
    parts = [make_part("base", [(-3, -base_h), (length + 3, -base_h), (length + 3, 0),
                                *studs_top(keys[0], -3, length + 3, 0), (-3, 0)])]
    for k, course in enumerate(courses):
        y0, y1 = k * h, (k + 1) * h
        for i, (x0, x1) in enumerate(course):
            ring = [(x0, y0)]
            for x, c in keys[k]:
                if x0 < x < x1:
                    ring += stud(x, c, y0)
            ring += [(x1, y0), (x1, y1)]
            if k + 1 < len(courses):
                ring += studs_top(keys[k + 1], x0, x1, y1)
            parts.append(make_part(f"b{k}_{i}", [*ring, (x0, y1)]))
    return parts


BOND = Family(
    "bond", "An English or Flemish bond wall on a footing, every brick keyed by a stud into the "
    "course above.",
    (Option("bond", "english: stretcher and header courses alternate; flemish: each course "
            "alternates stretchers and headers.", choices=("english", "flemish")),
     Option("courses", "Courses of bricks.", 1, 8, draw_low=2, draw_high=3),
     Option("stretchers", "Stretchers in a stretcher course (the wall's length).", 1, 6,
            default=2)),
    _bond, _count, ("bond", "courses", "stretchers"), training=False)
