"""The planning AND/OR graph: reachable subassemblies, dynamic programming over them, their trees.

A planning problem's AND/OR graph maps every subassembly reachable from the whole by candidate
splits (``PlanningProblem.candidates``) to its candidate operations, in the problem's order; an
*OR* node is a subassembly (one of its candidates is chosen), an *AND* node an operation (both of
its sides must be built). An interlocked subassembly (a dead end) has an empty tuple. This is the
operation space of one problem (its ``space``, its directions); ``rap.geometry.andor`` is the
geometric graph of an NDBG's partitions below it.

* ``reachable(problem, max_operations=None) -> Graph``: the walk (depth first, each subassembly
  once); past ``max_operations`` candidate operations in all it raises ``TooLarge``. Cost: one
  ``candidates`` call per reachable composite subassembly (memoised by the problem).
* ``dead_end(graph, whole)``: the subassembly to blame when no sequence exists.
* The dynamic programmes over the graph (the best product of scores) are in ``rap.plan.dp``.
* ``assembly_order(choice, whole)``: a decomposition tree's steps in assembly order (children
  before parents).
* ``Interlocked`` (a planner met a subassembly with no way on; ``subset`` names it) and
  ``TooLarge`` (the graph exceeds its operation budget): the errors of a search over the graph.

No ray, no torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rap.operation import Operation

if TYPE_CHECKING:
    from rap.plan.problem import PlanningProblem
    from rap.plan.report.result import PlanStep

__all__ = ["Graph", "Tree", "Interlocked", "TooLarge", "reachable", "dead_end", "assembly_order"]

#: subassembly -> its candidate operations (empty: interlocked)
Graph = dict[frozenset, tuple[Operation, ...]]
#: composite subassembly -> (index of the chosen candidate in ``graph[S]``, that operation)
Tree = dict[frozenset, tuple[int, Operation]]


class Interlocked(Exception):
    """No operation assembles ``subset``: a planner's search stops there (the planner reports it as
    infeasible, naming a minimal interlocked set)."""

    def __init__(self, subset: frozenset[str]):
        super().__init__(f"interlocked: {sorted(subset)}")
        self.subset = subset


class TooLarge(Exception):
    """The graph has more candidate operations than the walk's ``max_operations``."""


def reachable(problem: PlanningProblem, max_operations: int | None = None) -> Graph:
    """Every subassembly reachable from the whole by candidate splits, with its candidates (an
    interlocked one with an empty tuple); raises ``TooLarge`` past ``max_operations`` candidate
    operations in all (None: no limit)."""
    seen: Graph = {}
    stack = [problem.whole]
    n = 0
    while stack:
        s = stack.pop()
        if s in seen or len(s) < 2:
            continue
        c = problem.candidates(s)
        n += len(c)
        if max_operations is not None and n > max_operations:
            raise TooLarge(f"more than {max_operations} operations")
        seen[s] = c
        for op in c:
            stack += [op.moving, op.fixed]
    return seen


def dead_end(graph: Graph, whole: frozenset) -> frozenset:
    """The subassembly to blame when no sequence exists: the whole when it has no candidate,
    else the smallest interlocked subassembly reached."""
    locked = [s for s, c in graph.items() if not c]
    if whole in locked or not locked:
        return whole
    return min(locked, key=lambda s: (len(s), sorted(s)))


def assembly_order(choice: dict[frozenset, PlanStep], whole: frozenset[str]) -> list[PlanStep]:
    """Steps of a decomposition tree (subassembly -> chosen step) in assembly order: post-order,
    moving side first, then fixed side, then the step that joins them."""
    out: list[PlanStep] = []
    stack: list[tuple[frozenset, bool]] = [(whole, False)]
    while stack:
        s, expanded = stack.pop()
        if len(s) < 2:
            continue
        st = choice[s]
        if expanded:
            out.append(st)
        else:
            stack.append((s, True))
            stack.append((frozenset(st.fixed), False))
            stack.append((frozenset(st.moving), False))
    return out
