"""The robot cell's constraints applied to a problem's operations, and what blocks a plan.

``constrained_candidates(problem, subset, constraints)`` keeps, in the problem's order, the
operations of ``problem.splits(subset)`` that obey ``constraints`` (rules in
``rap.plan.constraints``): the base on the fixed side; one moving part with ``linear`` or
``gravity``; under ``gravity`` only subassemblies that hold the base, the whole assembly stable,
and each operation's fixed side stable (``problem.stability``, memoised per subset); with
``directions``, each operation re-aimed at the middle of its range's exact intersection with the
cones (``rap.geometry.cones.choose_direction``; the operation unchanged where the cones hold its
whole range), dropped where they do not meet. An operation from a ``partition_fn`` (no range) is
kept only when its own exact direction lies in a cone. Cost: per subset, one pass over its
splits plus one stability check per distinct fixed side.

``blocked_by(problem, subset)``: the subassembly and one line to blame when a planner found no
way on at ``subset``: a real interlock (no operation even without the constraints) is shrunk to a
minimal interlocked set and named as today (``rap.plan.result.interlocked_message``); otherwise
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
from rap.plan.constraints import SCORE_NOTE, CellConstraints
from rap.plan.result import interlocked_message

__all__ = ["constrained_candidates", "blocked_by", "constraint_stats", "reaim"]


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
    """The operations of ``subset`` that obey ``c`` (module doc), in the problem's order."""
    subset = frozenset(subset)
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
    seen: dict[str, Operation] = {}
    for op, part in problem.splits(subset):
        if c.base is not None and c.base in subset and c.base not in op.fixed:
            continue
        if (c.linear or gravity) and len(op.moving) != 1:
            continue
        if gravity and not problem.stability(op.fixed).stable:
            continue
        if arcs:
            op = reaim(op, part, arcs, prefer)
            if op is None:
                continue
        seen.setdefault(op.key(gh), op)
    return tuple(seen.values())


def _minimal_interlocked(problem, subset) -> frozenset:
    """An inclusion-minimal subset of ``subset`` with no operation even without constraints."""
    cur = sorted(subset)
    changed = True
    while changed and len(cur) > 2:
        changed = False
        for pid in list(cur):
            rest = [p for p in cur if p != pid]
            if len(rest) >= 2 and not problem.splits(rest):
                cur, changed = rest, True
                break
    return frozenset(cur)


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
    return f"{c.base} would have to move"


def blocked_by(problem, subset) -> tuple[frozenset, str]:
    """(the subassembly to blame, one line) for a planner stuck at ``subset`` (module doc)."""
    subset = frozenset(subset)
    name = problem.assembly.name
    c = problem.constraints
    if not problem.splits(subset) or not c.active or problem.candidates(subset):
        culprit = _minimal_interlocked(problem, subset) if not problem.splits(subset) else subset
        return culprit, interlocked_message(name, culprit)
    rules = c.rules()
    freeing = [r for r in rules if constrained_candidates(problem, subset, c.relaxed(r))]
    if "gravity" in freeing and "base" in freeing:
        freeing.remove("base")  # lifting the base lifts gravity too: gravity is the one to name
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
