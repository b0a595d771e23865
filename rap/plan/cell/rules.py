"""The robot cell's constraints applied to a problem's operations, and what blocks a plan.

``constrained_candidates(problem, subset, constraints)`` keeps, in the problem's order, the
operations of ``problem.splits(subset)`` that obey ``constraints`` (rules in
``rap.plan.cell.constraints``): the base on the fixed side; one moving part with ``linear`` or
``gravity``; under ``gravity`` only subassemblies that hold the base, the whole assembly stable,
and each operation's fixed side stable (``problem.stability``, memoised per subset); with
``layers``, no part of the fixed side lying wholly above the moving part (``part_heights``); with
``directions``, each operation re-aimed at the middle of its range's exact intersection with the
cones (``rap.geometry.cones.choose_direction``; the operation unchanged where the cones hold its
whole range), dropped where they do not meet. An operation from a ``partition_fn`` (no range) is
kept only when its own exact direction lies in a cone. An operation is kept only when both its
sides can be built under the same constraints (``buildable``, a memoised depth-first search), so
that greedy planners, which never go back, do not walk into a dead end the constraints make (a
wall whose bricks are taken away in an order that leaves one tipping). Cost: per subset, one pass
over its splits plus one stability check per distinct fixed side, plus the search's visits.

``blocked_by(problem, subset)``: the subassembly and one line to blame when a planner found no
way on at ``subset`` (followed down, through operations whose sides cannot be built, to one that
no operation obeying the rules splits): a real interlock (no operation even without the constraints) is shrunk to a
minimal interlocked set and named as today (``rap.plan.interlocked``); otherwise
the constraint that removes the subassembly's last operations is found by lifting the rules one
at a time (the rules whose lifting frees it are named together; all of them when none alone
does). ``constraint_stats(problem)``: what a plan's ``stats`` says about the constraints.

No ray, no torch.
"""

from __future__ import annotations

from fractions import Fraction

from rap.geometry.cones import intersect, partition_arc, choose_direction
from rap.geometry.exact import exact_direction, primitive
from rap.operation import Operation
from rap.plan.cell.constraints import SCORE_NOTE, CellConstraints
from rap.plan.interlocked import interlocked_message, minimal_interlocked

__all__ = ["constrained_candidates", "blocked_by", "constraint_stats", "reaim", "part_heights"]

def part_heights(problem, gravity) -> dict[str, tuple[Fraction, Fraction]]:
    """part id -> (lowest, highest) height of its vertices along ``-gravity`` (exact rationals,
    unnormalised: only comparisons matter) in ``problem``'s assembly. Part ``a`` lies wholly below
    ``b`` when ``highest(a) <= lowest(b)``. O(vertices) once per gravity, then memoised in
    ``problem.cell_memo`` (it lives as long as the problem)."""
    g = tuple(Fraction(v) for v in gravity)
    key = ("heights", g)
    hit = problem.cell_memo.get(key)
    if hit is None:
        ux, uy = -g[0], -g[1]
        hit = {}
        for part in problem.assembly.parts:
            h = [ux * x + uy * y for x, y in part.outer]
            hit[part.id] = (min(h), max(h))
        problem.cell_memo[key] = hit
    return hit


def reaim(op: Operation, partition, arcs, prefer) -> Operation | None:
    """``op`` aimed inside the removal ``arcs`` (cones): unchanged when they hold its whole
    range, re-aimed at the middle of the chosen piece, None when they miss it. Exact."""
    if partition is None:
        d = op.exact_direction if op.exact_direction is not None else op.direction
        removal = primitive(exact_direction((-Fraction(d[0]), -Fraction(d[1]))))
        return op if any(a.contains(removal) for a in arcs) else None
    arc = partition_arc(partition)
    pieces = intersect(arc, arcs)
    if not pieces:
        return None
    if pieces == [arc]:
        return op
    (dx, dy), (ux, uy) = choose_direction(arc, arcs, prefer)
    return Operation(op.moving, op.fixed, (-ux, -uy), (Fraction(-dx), Fraction(-dy)))


def constrained_candidates(problem, subset: frozenset, c: CellConstraints
                           ) -> tuple[Operation, ...]:
    """The operations of ``subset`` that obey ``c`` (module doc), in the problem's order, and
    whose two sides can themselves be built under ``c`` (``buildable``): a greedy planner never
    walks into a dead end that the constraints make."""
    subset = frozenset(subset)
    return tuple(op for op in _obeying(problem, subset, c)
                 if buildable(problem, op.moving, c) and buildable(problem, op.fixed, c))


def buildable(problem, subset, c: CellConstraints) -> bool:
    """Can ``subset`` be assembled under ``c``? A depth-first search for one sequence, memoised
    per (constraints, subset) in ``problem.cell_memo``; a single part is. Cost: at most one pass
    over the rules' operations of each subassembly it visits (its first success ends it; an
    unbuildable assembly visits every reachable one)."""
    subset = frozenset(subset)
    if len(subset) < 2:
        return True
    memo = problem.cell_memo
    key = ("buildable", c, subset)
    if key not in memo:
        memo[key] = any(_stands(problem, op, c) and buildable(problem, op.moving, c)
                        and buildable(problem, op.fixed, c)
                        for op in _search_order(problem, _rules(problem, subset, c), c))
    return memo[key]


def _stands(problem, op: Operation, c: CellConstraints) -> bool:
    return c.gravity is None or problem.stability(op.fixed).stable


def _search_order(problem, ops, c: CellConstraints):
    """Under gravity, the highest moving part first (taking the top off a stable pile seldom
    leaves it tipping): the search's first path then usually succeeds, with one stability check
    per step instead of one per operation."""
    if c.gravity is None:
        return ops
    heights = part_heights(problem, c.gravity)
    return sorted(ops, key=lambda op: -max(heights[p][1] for p in op.moving))


def _obeying(problem, subset: frozenset, c: CellConstraints) -> tuple[Operation, ...]:
    """The operations of ``subset`` that obey the rules of ``c``, memoised (module doc)."""
    key = ("obeying", c, subset)
    hit = problem.cell_memo.get(key)
    if hit is None:
        hit = tuple(op for op in _rules(problem, subset, c) if _stands(problem, op, c))
        problem.cell_memo[key] = hit
    return hit


def _rules(problem, subset: frozenset, c: CellConstraints) -> tuple[Operation, ...]:
    """The operations of ``subset`` that obey ``c`` but for their fixed side's stability."""
    key = ("rules", c, subset)
    hit = problem.cell_memo.get(key)
    if hit is None:
        hit = problem.cell_memo[key] = _apply_rules(problem, subset, c)
    return hit


def _apply_rules(problem, subset: frozenset, c: CellConstraints) -> tuple[Operation, ...]:
    if len(subset) < 2:
        return ()
    gravity = c.gravity is not None
    if gravity and (c.base not in subset
                    or (subset == problem.whole and not problem.stability(subset).stable)):
        return ()
    arcs = c.removal_arcs() if c.directions else []
    prefer = [primitive(exact_direction((-Fraction(x.axis[0]), -Fraction(x.axis[1]))))
              for x in c.directions]
    gh = problem.geometry_hash
    heights = part_heights(problem, c.gravity) if c.layers else None
    seen: dict[str, Operation] = {}
    for op, part in problem.splits(subset, c.one_part):
        if c.base is not None and c.base in subset and c.base not in op.fixed:
            continue
        if (c.linear or gravity) and len(op.moving) != 1:
            continue
        if heights is not None and _below_a_placed_part(heights, op):
            continue
        if arcs:
            op = reaim(op, part, arcs, prefer)
            if op is None:
                continue
        seen.setdefault(op.key(gh), op)
    return tuple(seen.values())


def _below_a_placed_part(heights, op: Operation) -> bool:
    """Does a moving part lie wholly below a part of the fixed side (``layers`` forbids it)?"""
    top = max(heights[p][1] for p in op.moving)
    return any(heights[f][0] >= top for f in op.fixed)


def _gravity_reason(problem, subset: frozenset, c: CellConstraints) -> str:
    """Why gravity removes the operations of ``subset`` (the first unstable state's reason)."""
    if c.base not in subset:
        return f"it does not hold the base {c.base}: nothing to stand on"
    if subset == problem.whole:
        whole = problem.stability(subset)
        if not whole.stable:
            return whole.reason
    for op in constrained_candidates(problem, subset, c.relaxed("gravity")):
        if len(op.moving) == 1:
            support = problem.stability(op.fixed)
            if not support.stable:
                return f"without {next(iter(op.moving))}: {support.reason}"
    return "no stable intermediate assembly"


def _why(problem, subset: frozenset, c: CellConstraints, rule: str) -> str:
    if rule == "gravity":
        return _gravity_reason(problem, subset, c)
    if rule == "directions":
        return "no insertion direction within " + " or ".join(x.describe() for x in c.directions)
    if rule == "linear":
        return "no single part can go in last"
    if rule == "layers":
        return "every part that could go in last lies wholly below a part already in place"
    return f"{c.base} would have to move"


def _deepest_block(problem, subset: frozenset, c: CellConstraints) -> frozenset:
    """Follow the first operation of ``subset`` with a side that cannot be built down to a
    subassembly that no operation obeying ``c`` splits at all: the one to blame."""
    while True:
        side = next((x for op in _obeying(problem, subset, c) for x in (op.moving, op.fixed)
                     if not buildable(problem, x, c)), None)
        if side is None:
            return subset
        subset = frozenset(side)


def blocked_by(problem, subset) -> tuple[frozenset, str]:
    """(the subassembly to blame, one line) for a planner stuck at ``subset`` (module doc)."""
    subset = frozenset(subset)
    name = problem.assembly.name
    c = problem.constraints
    if c.active and not problem.candidates(subset):
        subset = _deepest_block(problem, subset, c)
    if not problem.splits(subset, False):  # verified: no one-step translation separates it
        culprit = minimal_interlocked(subset, lambda rest: not problem.splits(rest, False))
        return culprit, interlocked_message(name, culprit)
    if not c.active or problem.candidates(subset):  # never claim an interlock not verified
        return subset, (f"no assembly sequence found below the subassembly "
                        f"{{{','.join(sorted(subset))}}}, which is not interlocked (a one-step "
                        f"translation separates it): the search gave up on {name} (try "
                        f"--method sim)")
    rules = c.rules()
    freeing = [r for r in rules if _obeying(problem, subset, c.relaxed(r))]
    # lifting the base lifts gravity and layers, lifting gravity lifts layers: name the narrowest
    for narrow, wider in (("layers", ("gravity", "base")), ("gravity", ("base",))):
        if narrow in freeing:
            freeing = [r for r in freeing if r not in wider]
    parts = "{" + ",".join(sorted(subset)) + "}"
    head = f"no sequence satisfies the cell's constraints: the subassembly {parts} cannot be built"
    if len(freeing) == 1:
        rule = freeing[0]
        return subset, (f"{head}: every way to split it breaks {c.flag(rule)} "
                        f"({_why(problem, subset, c, rule)})")
    named = freeing or list(rules)
    return subset, (f"{head}: every way to split it breaks one of "
                    f"{', '.join(c.flag(r) for r in named)}")


def constraint_stats(problem) -> dict:
    """``{"constraints": to_json(), "score_note": SCORE_NOTE}`` when the problem has
    constraints, else ``{}``."""
    c = problem.constraints
    if not c.active:
        return {}
    return {"constraints": c.to_json(), "score_note": SCORE_NOTE}
