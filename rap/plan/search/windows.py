"""Windows: a plan's runs of one-part steps re-ordered exactly, a few steps at a time.

Beyond a few dozen parts a plan is mostly a *run*: each step splits one part off the rest, and
the rest is split next. ``polish(problem, scores, plan, width, budget, stats)`` cuts every run into
windows of ``width`` consecutive steps and, in each, looks for a better order in which to split
the window's parts off the window's first subassembly: a dynamic programme over the subsets of the
window's parts (``2 ** width`` subassemblies), refined as the search refines: the order with the
best product of the search's scores (``SearchScores.of``: simulated where known, else the model's
raised score) is chosen, its unsimulated steps are simulated, and the choice is made again, until
it is settled (at most ``width`` rounds). The best fully simulated order is kept when it beats the
window's own (the scores greedy or the search already simulated count). The window's last
subassembly, and everything below it, stays as it was, so the plan's robustness is multiplied by
the window's gain.

Windows are taken top down, the plan's first steps first; ``budget`` fresh simulations in all (a
window that would pass it, and every later one, is left as it is), and none is started past a
``deadline`` (the search's time limit). A window whose steps are not
all simulated is left as it is. Stats: ``windows`` (re-ordered / visited), ``window_simulations``,
``window_gain`` (the product of the gains).

What it can give at most (``python -m research.window_reorder``: every window's every candidate
simulated, windows of 4): gains of 1.13 (wall 44), 1.12 (grid 49), 1.25 (convex 30) and 1.16
(herringbone 36) for 40-116 simulations on greedy's chains.

Cost: per window at most ``width`` rounds of at most ``width`` simulations, one scorer batch of
predictions, and ``2 ** width`` candidate lists (memoised by the problem). No ray, no torch.
"""

from __future__ import annotations

import time
from itertools import combinations

from rap.plan.problem import PlanningProblem

__all__ = ["polish", "runs"]


def _one_part_step(op) -> tuple[frozenset, frozenset] | None:
    """(the part split off, the rest) when ``op`` splits one part off two or more, else None."""
    for one, rest in ((op.moving, op.fixed), (op.fixed, op.moving)):
        if len(one) == 1 and len(rest) >= 2:
            return one, rest
    return None


def runs(plan: dict, whole: frozenset) -> list[list[frozenset]]:
    """The plan's runs, top down: each a list of subassemblies ``S_0 ⊃ S_1 ⊃ ...``, where every
    ``S_i``'s step splits one part off and ``S_{i+1}`` is the rest (at least two steps a run)."""
    out, stack, seen = [], [whole], set()
    while stack:
        s = stack.pop()
        if len(s) < 2 or s in seen:
            continue
        run = [s]
        while (step := _one_part_step(plan[run[-1]])) is not None:
            seen.add(run[-1])
            run.append(step[1])
        seen.add(run[-1])
        if len(run) >= 3:
            out.append(run)
        last = plan[run[-1]]  # not a one-part step: both its sides are planned below it
        stack += [last.moving, last.fixed]
    return out


def polish(problem: PlanningProblem, scores, plan: dict, width: int, budget: int,
           stats: dict, deadline: float | None = None) -> dict:
    """``plan`` (subassembly -> operation) with its runs' windows re-ordered (module doc); no
    window is started after ``deadline`` (a ``time.perf_counter()`` value; None: none)."""
    plan = dict(plan)
    spent, changed, visited, gain = 0, 0, 0, 1.0
    stopped = None  # "time" (the deadline) or "budget": this window and the rest stay as they are
    for run in runs(plan, problem.whole):
        for i in range(0, len(run) - 1, width):
            if deadline is not None and time.perf_counter() > deadline:
                stopped = "time"
                break
            start, end = run[i], run[min(i + width, len(run) - 1)]
            old = [plan[s] for s in run[i:min(i + width, len(run) - 1)]]
            if not all(scores.is_simulated(op) for op in old):
                continue
            order = _best_order(problem, scores, start, end, budget - spent)
            if order is None:
                stopped = "budget"
                break
            value, steps, used = order
            spent += used
            visited += 1
            before = 1.0
            for op in old:
                before *= scores.known(op)
            if value > before:
                for s in run[i:min(i + width, len(run) - 1)]:
                    del plan[s]
                plan.update(steps)
                changed += 1
                gain *= value / before
        if stopped:
            break
    stats.update(windows=f"{changed}/{visited}", window_simulations=spent, window_gain=gain)
    if stopped == "time":
        stats["windows_stopped"] = "time"
    return plan


def _best_order(problem, scores, start: frozenset, end: frozenset, budget: int):
    """``(value, {subassembly: operation}, fresh simulations)``: the best order by simulated
    scores of splitting ``start - end``'s parts off ``start`` one at a time, found as the search
    refines (module doc); None when the budget cannot pay for the first round."""
    parts = sorted(start - end)
    layers: dict[frozenset, list] = {}
    for k in range(len(parts)):
        for s in _subsets_removed(start, parts, k):
            layers[s] = [op for op in problem.candidates(s)
                         if (step := _one_part_step(op)) is not None
                         and step[0] <= start - end]
    scores.predict([op for ops in layers.values() for op in ops])
    fresh = 0
    for _ in range(len(parts)):  # rounds: choose by the search's scores, simulate the choice
        _, steps = _dp(layers, end, start, scores.of)
        todo = [op for op in steps.values() if not scores.is_simulated(op)]
        if not todo:
            break
        if fresh + len(todo) > budget:
            if not fresh:
                return None
            break
        scores.simulate(todo)
        fresh += len(todo)
    value, steps = _dp(layers, end, start, scores.simulated_or_0)
    return value, steps, fresh


def _dp(layers: dict, end: frozenset, start: frozenset, score) -> tuple[float, dict]:
    """The best product of ``score`` over the window's orders, and its steps (ties: the first
    candidate); ``(0.0, {})`` when no order has a positive product."""
    best: dict[frozenset, tuple[float, object]] = {end: (1.0, None)}
    for s in sorted(layers, key=len):  # smaller first: the rest of each step is done
        cands = [(score(op) * best[rest][0], op) for op in layers[s]
                 if (rest := _one_part_step(op)[1]) in best]
        if cands:
            best[s] = max(cands, key=lambda c: c[0])
    if start not in best or best[start][0] <= 0.0:
        return 0.0, {}
    steps, s = {}, start
    while s != end:
        op = best[s][1]
        steps[s] = op
        s = _one_part_step(op)[1]
    return best[start][0], steps


def _subsets_removed(start: frozenset, parts: list, k: int):
    """``start`` less every ``k``-subset of ``parts``."""
    for removed in combinations(parts, k):
        yield start - frozenset(removed)
