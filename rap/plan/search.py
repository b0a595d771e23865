"""Near-optimal sequences at the model's cost: search over the AND/OR graph with learned scores.

``SearchPlanner`` maximises the product of step scores over assembly sequences, like
``OptimalPlanner``, but with the CNN's *expected score* of an operation (``Scorer.expected_scores``:
the binomial head's calibrated success rate) standing in for the simulator, which is then spent
only where it decides:

1. **Exact** (the operation space has at most ``max_operations`` candidate operations): dynamic
   programming over the reachable subassemblies, ``best(S) = max r(op) best(M) best(F)`` (the
   optimum's own recursion and tie-breaking, by branch and bound: ``rap.plan.bounded_dp``, which
   renders and scores a subassembly's candidates only when it can still matter), where ``r(op)``
   is the simulated score of an operation already simulated and the model's expected score
   otherwise. An interlocked subassembly is a dead end (``best = 0``), not a failure.
2. **Beam** (beyond the budget, e.g. 30 or 100 parts): top-down beam search: every state is a
   partial decomposition; each round expands the largest open subassembly of every state with all
   its candidates and keeps the ``beam_width`` states of highest score product (all states hold
   the same number of operations, so products compare fairly). Predictions are cached by
   operation key across states; memory is O(beam_width x parts) states plus the cache.
3. **Simulations where they matter**: up to ``simulations`` fresh simulations (default 0). In
   exact mode, the operations of the chosen sequence that were not simulated yet are simulated
   (one batch per round), their scores replace the predictions, and the DP is solved again, until
   every operation of the chosen sequence is simulated or trusted, or the budget is spent. An
   operation is *trusted* when its predicted score is at least ``trust`` (None: none is): the
   model is then sure enough that it succeeds (0.97 on the binomial head is P(high) of about 0.9)
   and a simulation would rarely change the choice. In beam mode the same is done over the final
   beam's complete sequences (re-ranked by mixed products).
4. **Optimism** ``u`` in [0, 1] (default 0): while choosing, an operation neither simulated nor
   trusted counts as ``p + u (1 - p)`` (its predicted failure rate shrunk by ``1 - u``), so an
   alternative the model may underrate gets chosen, simulated and kept if it holds up. ``u = 0``
   is the plain model; with ``u = 1`` every unsimulated operation is an upper bound (1), and
   exact mode with the budget not spent returns the optimum's robustness whatever the model says
   (a best-first search; on held-out assemblies it simulated half the operations). When the
   budget runs out first, the plan is chosen again without optimism (by what is known). The
   plan's scores are reported without optimism.

With a perfect model (predictions equal to the simulator's scores) the exact mode returns the
optimum exactly. Each step of the plan says where its score came from: ``sim`` or ``cnn``.

Cost: one CNN batch per subassembly visited (exact; on held-out assemblies 65-71% of the graph's
operations on average) or per round's candidates (beam), plus the simulations asked for. No ray,
no torch.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

from rap.plan.bounded_dp import dp_choice_bounded
from rap.plan.graph import Interlocked, TooLarge, assembly_order, dead_end, reachable
from rap.plan.planners import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.result import PlanStep
from rap.plan.scorers import Scorer

__all__ = ["SearchPlanner", "DEFAULT_BEAM", "DEFAULT_MAX_OPERATIONS"]

DEFAULT_BEAM = 8
DEFAULT_MAX_OPERATIONS = 20_000


@dataclass
class _Scores:
    """The score of each operation as far as known: simulated (exact) or predicted."""

    problem: PlanningProblem
    scorer: Scorer
    predicted: dict
    simulated: dict
    optimism: float = 0.0
    trust: float | None = None

    def predict(self, ops) -> None:
        todo = {}
        for op in ops:
            k = self.problem.key(op)
            if k not in self.predicted and k not in todo:
                todo[k] = op
        if todo:
            for k, v in zip(todo, self.scorer.expected_scores(self.problem, list(todo.values()))):
                self.predicted[k] = float(v)

    def of(self, op) -> float:
        """The score the search chooses by: simulated, else predicted (raised by the optimism
        unless trusted)."""
        k = self.problem.key(op)
        if k in self.simulated:
            return self.simulated[k]
        p = self.predicted[k]
        if self.optimism and (self.trust is None or p < self.trust):
            return p + self.optimism * (1.0 - p)
        return p

    def known(self, op) -> float:
        """The score without optimism: simulated, else predicted."""
        k = self.problem.key(op)
        return self.simulated[k] if k in self.simulated else self.predicted[k]

    def simulate(self, ops) -> None:
        ops = [op for op in ops if self.problem.key(op) not in self.simulated]
        for op, sc in zip(ops, self.scorer.scores(self.problem, ops)):
            self.simulated[self.problem.key(op)] = float(sc)


class SearchPlanner(Planner):
    """See the module docstring. ``rap.plan.methods.SearchOptions`` declares the options (ranges,
    defaults) and checks them; they are not checked here."""

    name = "search"

    def __init__(self, beam_width: int = DEFAULT_BEAM, max_operations: int = DEFAULT_MAX_OPERATIONS,
                 simulations: int = 0, trust: float | None = None, lazy: bool = True,
                 optimism: float = 0.0):
        self.optimism = float(optimism)
        self.beam_width = int(beam_width)
        self.max_operations = int(max_operations)
        self.simulations = int(simulations)
        self.trust = None if trust is None else float(trust)
        self.lazy = bool(lazy)  # False: score the whole graph in one batch first (same plan)

    def _to_simulate(self, scores: "_Scores", ops) -> list:
        """The operations of a chosen sequence still worth a simulation: not simulated, and not
        trusted (predicted score below ``trust``)."""
        key = scores.problem.key
        return [op for op in ops if key(op) not in scores.simulated
                and (self.trust is None or scores.predicted[key(op)] < self.trust)]

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        if len(whole) < 2:
            return []
        scores = _Scores(problem, scorer, {}, {}, self.optimism, self.trust)
        try:
            graph = reachable(problem, self.max_operations)
        except TooLarge:
            graph = None
        if graph is not None:
            stats["search"] = "exact"
            trees = self._exact(graph, scores, whole, stats)
        else:
            stats["search"] = "beam"
            trees = self._beam(problem, scores, whole, stats)
        steps = {}
        for sub, op in trees.items():
            k = problem.key(op)
            steps[sub] = PlanStep.of(op, "sim" if k in scores.simulated else "cnn",
                                     score=scores.simulated.get(k),
                                     confidence=scores.predicted.get(k))
        stats["search_simulations"] = len(scores.simulated)
        stats["predicted_operations"] = len(scores.predicted)
        return assembly_order(steps, whole)

    # -- exact ------------------------------------------------------------------------------------
    def _exact(self, graph, scores: _Scores, whole, stats) -> dict:
        stats.update(subassemblies=len(graph), operations=sum(len(c) for c in graph.values()))
        if not self.lazy:
            scores.predict([op for c in graph.values() for op in c])

        def scores_of(s):  # predicted on the first visit, one CNN batch per subassembly
            scores.predict(graph[s])
            return [scores.of(op) for op in graph[s]]

        spent = 0
        while True:
            best, tree = dp_choice_bounded(graph, scores_of, whole)
            if best <= 0.0:
                raise Interlocked(dead_end(graph, whole))
            choice = {sub: op for sub, (_, op) in tree.items()}
            todo = self._to_simulate(scores, choice.values())
            if todo and spent >= self.simulations and scores.optimism:
                # budget spent with raised scores still in the choice: choose by what is known
                scores.optimism = 0.0
                continue
            if not todo or spent >= self.simulations:
                stats["predicted_robustness"] = math.prod(scores.known(op)
                                                          for op in choice.values())
                return choice
            todo = todo[:self.simulations - spent]
            scores.simulate(todo)
            spent += len(todo)

    # -- beam -------------------------------------------------------------------------------------
    def _beam(self, problem: PlanningProblem, scores: _Scores, whole, stats) -> dict:
        # a state: (log product, tie-break counter, open subassemblies largest first, choices)
        beam = [(0.0, 0, (whole,), ())]
        counter = 1
        rounds = 0
        while any(st[2] for st in beam):
            rounds += 1
            expand = [st for st in beam if st[2]]
            done = [st for st in beam if not st[2]]
            cands = {}
            for _, _, open_, _ in expand:
                s = open_[0]
                if s not in cands:
                    cands[s] = problem.candidates(s)
            scores.predict([op for c in cands.values() for op in c])
            nxt = list(done)
            for logp, _, open_, chosen in expand:
                s, rest = open_[0], open_[1:]
                for op in cands[s]:
                    r = scores.of(op)
                    if r <= 0.0:
                        continue
                    kids = tuple(x for x in (op.moving, op.fixed) if len(x) >= 2)
                    new_open = tuple(sorted(rest + kids, key=lambda x: (-len(x), sorted(x))))
                    nxt.append((logp + math.log(r), counter, new_open, chosen + ((s, op),)))
                    counter += 1
            if not nxt:
                raise Interlocked(whole)
            beam = heapq.nlargest(self.beam_width, nxt, key=lambda st: (st[0], -st[1]))
        stats.update(beam_rounds=rounds, beam_width=self.beam_width)
        # simulations where they matter: re-rank the final sequences by mixed products
        spent = 0
        while True:
            ranked = sorted(beam, key=lambda st: (-sum(math.log(max(scores.of(op), 1e-300))
                                                       for _, op in st[3]), st[1]))
            top = ranked[0][3]
            todo = self._to_simulate(scores, [op for _, op in top])
            if todo and spent >= self.simulations and scores.optimism:
                scores.optimism = 0.0  # as in exact mode: the budget is spent, rank by what is known
                continue
            if not todo or spent >= self.simulations:
                stats["predicted_robustness"] = math.prod(scores.known(op) for _, op in top)
                return dict(top)
            todo = todo[:self.simulations - spent]
            scores.simulate(todo)
            spent += len(todo)
