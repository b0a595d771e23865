"""The one home of "which parts lock each other": a minimal interlocked subassembly, and its line.

A subassembly is *interlocked* when no one-step translation separates it (no candidate operation,
with the robot cell's rules lifted). A plan that fails there names an inclusion-minimal such set,
never a set that is not verified interlocked (``rap.plan.cell.rules.blocked_by`` says so in
other words then).

* ``minimal_interlocked(subset, interlocked)``: the first pair, in id order, that is interlocked
  by itself (two parts that block each other in every direction, such as two jigsaw pieces);
  else parts dropped in id order, pass after pass, while the rest (at least 2 parts) stays
  interlocked, until a pass drops none. O(n^2) calls of the test ``interlocked(parts)`` (e.g.
  ``lambda s: not problem.splits(s, False)``) on pairs, which are cheap, then O(n) per pass.
* ``interlocked_message(assembly, parts)``: the one-line reason of an ``INFEASIBLE`` plan.

No ray, no torch; imports nothing of rap.
"""

from __future__ import annotations

from itertools import combinations
from typing import Callable, Iterable

__all__ = ["minimal_interlocked", "interlocked_message"]


def minimal_interlocked(subset: Iterable[str],
                        interlocked: Callable[[frozenset], bool]) -> frozenset[str]:
    """An inclusion-minimal interlocked subset of ``subset`` (module doc); ``subset`` itself when
    the test does not hold for it (a caller names it interlocked only when it does)."""
    cur = sorted(subset)
    if not interlocked(frozenset(cur)):
        return frozenset(cur)
    for pair in combinations(cur, 2):  # a pair that locks is as small as an interlock gets
        if interlocked(frozenset(pair)):
            return frozenset(pair)
    changed = True
    while changed and len(cur) > 2:
        changed = False
        for pid in list(cur):
            rest = [p for p in cur if p != pid]
            if len(rest) >= 2 and interlocked(frozenset(rest)):
                cur, changed = rest, True
    return frozenset(cur)


def interlocked_message(assembly: str, parts) -> str:
    """The one-line reason of an ``INFEASIBLE`` result whose minimal interlocked set is ``parts``."""
    return (f"no one-step translation separates the subassembly {{{','.join(sorted(parts))}}}: "
            f"it is interlocked, so {assembly} has no assembly sequence")
