"""Branch and bound on the model's uncertainty: what a search knows of each operation, and bounds.

``SearchScores`` holds, for one search, every operation's score as far as known: the simulator's
(exact) where simulated, else the model's expected score ``p`` and its conformal upper bound ``u``
at a per-operation level (``rap.model.calibration``). Three views:

* ``known(op)``: simulated, else ``p`` (what a plan is chosen by when the budget is spent);
* ``high(op)``: simulated, else ``u``: an upper bound on the simulated score. With ``level =
  bonferroni(confidence, n - 1)`` (``1 - (1 - confidence) / (n - 1)``, the union bound over a
  sequence's ``n - 1`` steps) the bounds of all steps of one sequence (the optimum's, say) hold
  together with probability at least ``confidence``, so ``V = max over sequences of the product
  of high`` is an upper bound on the optimum's robustness at that confidence. The guarantee is
  split conformal's: for operations exchangeable with the calibration set; that the optimum's
  steps are chosen by their scores is not covered by it, which is why coverage is *measured*
  (docs/RESULTS.md);
* ``of(op)`` (what the search chooses by): simulated; else ``p`` when trusted (``p >= trust``);
  else ``max(p + optimism (1 - p), p + upper (u - p))``: the constant optimism of earlier releases
  and the bound's share ``upper`` in [0, 1], whichever is the larger (``upper = 0``: the constant
  optimism alone, as before; ``upper = 1, optimism = 0``: the bound itself). ``lower()`` (choose
  by ``known``) and ``by_bounds()`` (by ``high``) change it for the rest of a search.

A free operation (``PlanningProblem.is_free``: robust by geometry, 1 exactly) is known, never
predicted: ``predict`` and ``add_simulated`` enter it with its exact 1 (in ``simulated``, its key
also in ``free``), so it carries no prediction, no conformal bound and no simulation, and counts
in neither the model's numbers nor the budget (``simulations``: the real simulations known).

``incumbent(graph, scores, whole)``: the best
sequence all of whose operations are simulated (its robustness and tree; 0 and None when there is
none). ``report(...)``: the ``bound`` block of a plan (``rap.plan.report.result.PlanResult``).

Cost: ``incumbent`` at most one visit of each reachable subassembly; the upper bounds of a batch of predictions are one vectorised call. No ray, no torch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rap.model.calibration import ScoreBounds
from rap.plan.dp import dp_choice_bounded
from rap.plan.graph import Graph
from rap.plan.problem import PlanningProblem
from rap.plan.scoring.scorer import ScorerProtocol

__all__ = ["SearchScores", "incumbent", "report"]


@dataclass
class SearchScores:
    """The scores one search knows (module doc). ``level``: the per-operation level of the upper
    bounds (``bonferroni(confidence, steps)``)."""

    problem: PlanningProblem
    scorer: ScorerProtocol
    bounds: ScoreBounds = field(default_factory=ScoreBounds.trivial)
    level: float = 0.95
    optimism: float = 0.0
    upper: float = 0.0
    trust: float | None = None
    predicted: dict = field(default_factory=dict)
    bound: dict = field(default_factory=dict)  # key -> upper bound of an unsimulated operation
    simulated: dict = field(default_factory=dict)  # key -> exact score (simulated, or free: 1)
    free: set = field(default_factory=set)  # keys of the free operations in ``simulated``
    # id(op) -> (op, key): a key is a SHA-256 of the operation's content, the search's main
    # bookkeeping cost when recomputed; the op is held so that its id is never reused
    _keys: dict = field(default_factory=dict, repr=False)
    # view -> subassembly -> its candidates' scores in that view; dropped for a subassembly when
    # one of its operations is predicted or simulated, for every one when the view changes
    _lists: dict = field(default_factory=lambda: {"of": {}, "high": {}, "simulated_or_0": {}},
                         repr=False)
    # view -> the (exact, bounded) tables of the dynamic programmes over that view, kept between
    # rounds: an entry is dropped when a subassembly it contains changes scores in that view
    _memo: dict = field(default_factory=lambda: {v: ({}, {}) for v in
                                                 ("of", "high", "simulated_or_0")}, repr=False)

    def key(self, op) -> str:
        """``problem.key(op)``, memoised by the operation object."""
        hit = self._keys.get(id(op))
        if hit is not None and hit[0] is op:
            return hit[1]
        k = self.problem.key(op)
        self._keys[id(op)] = (op, k)
        return k

    def scores(self, view: str, s: frozenset, ops) -> list:
        """``[self.of(op) for op in ops]`` (or ``high``, ``simulated_or_0``: the ``view``) for
        ``ops``, the candidates of ``s`` (the same list each time), memoised until one of them is
        predicted or simulated (module doc)."""
        cache = self._lists[view]
        out = cache.get(s)
        if out is None:
            f = {"of": self.of, "high": self.high, "simulated_or_0": self.simulated_or_0}[view]
            out = cache[s] = [f(op) for op in ops]
        return out

    def memo(self, view: str) -> tuple[dict, dict]:
        """The tables a dynamic programme over ``view``'s scores keeps between calls
        (``rap.plan.dp.dp_choice_bounded``'s ``memo``; ``max_value``'s)."""
        return self._memo[view]

    def cached(self, view: str, s: frozenset) -> bool:
        """Whether ``scores(view, s, ...)`` is memoised (then its operations are predicted)."""
        return s in self._lists[view]

    def _changed(self, ops, views=("of", "high", "simulated_or_0")) -> None:
        """Forget the scores of ``ops``' subassemblies and the values over ``views`` of every
        subassembly containing one of them."""
        subs = {op.moving | op.fixed for op in ops}
        for view, cache in self._lists.items():
            # a value below S was computed from S's scores, which stay listed until now
            read = [s for s in subs if cache.pop(s, None) is not None]
            if read and view in views:
                for table in self._memo[view]:
                    for s in [s for s in table if any(x <= s for x in read)]:
                        del table[s]

    @property
    def raised(self) -> bool:
        """Whether the search chooses by raised scores (optimism or the bounds' share)."""
        return bool(self.optimism or self.upper)

    def lower(self) -> None:
        """Choose by what is known from now on (the budget is spent)."""
        self._choose(0.0, 0.0, self.trust)

    def by_bounds(self) -> None:
        """Choose by the upper bounds themselves from now on (``of`` is ``high`` for every
        predicted operation: upper 1, no optimism, no trust), so the choice's value is ``V``."""
        self._choose(0.0, 1.0, None)

    def _choose(self, optimism: float, upper: float, trust: float | None) -> None:
        self.optimism, self.upper, self.trust = optimism, upper, trust
        self._forget("of")

    def _forget(self, view: str) -> None:
        """Drop every memoised score list and table of ``view``."""
        self._lists[view].clear()
        for table in self._memo[view]:
            table.clear()

    def predict(self, ops) -> None:
        """The model's expected score (and its upper bound) of each operation not predicted yet,
        in one CNN batch; a free operation is entered as known, 1, instead (module doc)."""
        todo, free = {}, []
        for op in ops:
            k = self.key(op)
            if k in self.predicted or k in todo or k in self.free:
                continue
            if self.scorer.is_free(self.problem, op):
                free.append(op)
            else:
                todo[k] = op
        if free:
            self.add_simulated(free, [1.0] * len(free))
        if todo:
            p = np.asarray(self.scorer.expected_scores(self.problem, list(todo.values())),
                           dtype=np.float64)
            u = self.bounds.upper(p, self.level)
            for k, v, w in zip(todo, p, u):
                self.predicted[k] = float(v)
                self.bound[k] = float(w)
            # first scores: only the bounds (1 before) can have been read, by ``high``
            self._changed(todo.values(), ("high",))

    def of(self, op) -> float:
        """The score the search chooses by (module doc)."""
        k = self.key(op)
        if k in self.simulated:
            return self.simulated[k]
        p = out = self.predicted[k]
        if self.trust is not None and p >= self.trust:
            return p
        if self.optimism:
            out = p + self.optimism * (1.0 - p)
        if self.upper:
            out = max(out, p + self.upper * (self.bound[k] - p))
        return out

    def known(self, op) -> float:
        """Simulated, else predicted."""
        k = self.key(op)
        return self.simulated[k] if k in self.simulated else self.predicted[k]

    def high(self, op) -> float:
        """Simulated, else the upper bound (1 for an operation not predicted)."""
        k = self.key(op)
        return self.simulated[k] if k in self.simulated else self.bound.get(k, 1.0)

    def is_simulated(self, op) -> bool:
        return self.key(op) in self.simulated

    def simulate(self, ops) -> None:
        """Simulate the operations not simulated yet (one batch)."""
        ops = [op for op in ops if self.key(op) not in self.simulated]
        self.add_simulated(ops, [float(sc) for sc in self.scorer.scores(self.problem, ops)])

    def add_simulated(self, ops, scores) -> None:
        """Scores simulated elsewhere (a plan's evaluation)."""
        ops = list(ops)
        for op, sc in zip(ops, scores):
            k = self.key(op)
            self.simulated[k] = float(sc)
            if self.scorer.is_free(self.problem, op):
                self.free.add(k)
        self._changed(ops)

    @property
    def simulations(self) -> int:
        """How many of the known scores were simulated (free operations are not)."""
        return len(self.simulated) - len(self.free)

    def simulated_or_0(self, op) -> float:
        """Simulated, else 0 (what the incumbent is chosen by)."""
        return self.simulated.get(self.key(op), 0.0)


def incumbent(graph: Graph, scores: SearchScores, whole: frozenset) -> tuple[float, dict | None]:
    """The best sequence whose operations are all simulated: (its robustness, subassembly ->
    operation), or (0.0, None) when no such sequence exists. No prediction is asked for."""
    def scores_of(s):
        return scores.scores("simulated_or_0", s, graph[s])

    best, tree = dp_choice_bounded(graph, scores_of, whole, scores.memo("simulated_or_0"))
    if best <= 0.0:
        return 0.0, None
    return best, {sub: op for sub, (_, op) in tree.items()}


def report(robustness: float, value: float, confidence: float, scope: str,
           bounds: ScoreBounds, steps: int, level: float) -> dict:
    """A plan's ``bound`` block: the optimum's upper bound ``V`` (raised to the plan's own
    ``robustness`` where rounding left it below), the confidence, the plan's gap ``1 - R / V``,
    the scope (``exact``: every sequence; ``beam``: the final beam's only) and a note on where the
    bounds came from."""
    v = max(float(value), float(robustness))
    if bounds.perfect:
        note = "a perfect scorer: the bound is the optimum"
    elif not bounds.calibrated:
        note = bounds.provenance.get("note", "no calibration: unsimulated operations bounded by 1")
    else:
        src = bounds.provenance
        what = ", ".join(str(src[k]) for k in ("model", "set", "date") if k in src)
        note = (f"split-conformal bounds per operation at level {level:.4g} (Bonferroni over "
                f"{steps} steps)" + (f", calibrated: {what}" if what else ""))
    if scope == "beam":
        note += "; over the final beam's sequences only, not every sequence"
    return {"robustness_upper": v, "confidence": float(confidence),
            "gap": 0.0 if v <= 0 else max(0.0, 1.0 - float(robustness) / v),
            "scope": scope, "note": note}
