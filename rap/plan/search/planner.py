"""Near-optimal sequences at the model's cost: search over the AND/OR graph with learned scores.

``SearchPlanner`` maximises the product of step scores over assembly sequences, like
``OptimalPlanner``, but with the CNN's *expected score* of an operation (``Scorer.expected_scores``:
the binomial head's calibrated success rate) standing in for the simulator, which is then spent
only where it decides:

1. **Exact** (the operation space has at most ``max_operations`` candidate operations): dynamic
   programming over the reachable subassemblies, ``best(S) = max r(op) best(M) best(F)`` (the
   optimum's own recursion and tie-breaking, by branch and bound: ``rap.plan.dp``, which
   renders and scores a subassembly's candidates only when it can still matter), where ``r(op)``
   is the simulated score of an operation already simulated and the model's expected score
   otherwise. An interlocked subassembly is a dead end (``best = 0``), not a failure.
2. **Beam** (beyond the budget, e.g. 30 or 100 parts): top-down beam search: every state is a
   partial decomposition; each round expands the largest open subassembly of every state with all
   its candidates and keeps the ``beam_width`` states of highest score product (all states hold
   the same number of operations, so products compare fairly). Predictions are cached by
   operation key across states; memory is O(beam_width x parts) states plus the cache.
3. **Simulations where they matter**: up to ``simulations`` fresh simulations (here 0; ``plan``'s
   default, ``rap.plan.methods.SearchOptions``: 200 with ``upper`` 0.35 and ``gap`` 0.05). In
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

5. **Bounds** (``rap.plan.search.scores``): every unsimulated operation also has an upper bound
   ``u`` on its simulated score, split-conformal from the model's expected score
   (``rap.model.calibration``, the shipped calibration ``rap/data/score_bounds.json``; without it
   every ``u`` is 1), at the per-operation level ``1 - (1 - confidence) / (n - 1)`` (Bonferroni
   over a sequence's ``n - 1`` steps). ``V``, the best product of ``u`` (simulated scores where
   known) over every sequence, bounds the optimum's robustness at ``confidence`` (default 0.95).
   ``upper`` ``w`` in [0, 1] (default 0: off) makes an unsimulated, untrusted operation count as
   ``max(p + u_opt (1 - p), p + w (u - p))`` while choosing (``u_opt`` the optimism; the larger
   of the two raises). With ``upper > 0`` each round simulates ``bound_round`` (``BOUND_ROUND``,
   2) of the optimistic sequence's unsimulated, untrusted operations, the most raised first
   (largest chosen / known score), instead of all of them. With ``upper = 1`` (no optimism, no
   trust) the choice's value is ``V`` and this is branch and bound: the search stops when the
   best fully simulated sequence (the *incumbent* ``I``) reaches ``V`` (nothing left can beat
   it). With ``gap`` (None or 0: off; any ``upper`` or optimism) ``V`` is computed each round
   and the search stops once ``I >= (1 - gap) V``. With ``simulations`` 0, optimism, ``upper``
   and ``gap`` change nothing (the plan is chosen by the model's scores alone). Otherwise it
   stops when the choice is settled or the budget spent (then the plan is chosen by what is
   known, as above); a stop by ``gap`` or ``V`` returns the incumbent (``stats["stopped"]``:
   ``settled``, ``budget``, ``gap`` or ``bound``, ``stats["stopped_after"]`` the simulations
   spent). In beam mode ``V`` and the incumbent range over the final beam's sequences only
   (reported as the bound's ``scope``: ``beam``).

   **Phase 2: simulating until within the gap.** When the choice is settled (every operation
   simulated or trusted) but ``gap`` is set, ``I < (1 - gap) V`` and budget remains, the search
   goes on as branch and bound on the bounds themselves (``SearchScores.by_bounds``: upper 1,
   no optimism, no trust): each round simulates ``bound_round`` of the unsimulated operations
   of the sequence achieving ``V``, the most raised first, until ``I >= (1 - gap) V`` (stop
   ``gap``), ``I >= V`` (``bound``: no sequence left can beat it) or the budget is spent
   (``budget``). Its plan is always the incumbent, never chosen again from unsimulated
   operations, or phase 1's settled choice where that is better by known scores (possible only
   with trusted operations in it): phase 2 can only lower ``V`` or find a better fully
   simulated plan, never return a worse one than phase 1's. ``stats``: ``phase1_simulations``,
   ``phase2_simulations``, ``search_bound`` (``V`` when it stopped). The same in beam mode,
   over the final beam's sequences. With ``upper`` 1, no optimism and no trust, phase 1 is
   this already.
6. **A bound with every plan**: after the plan's steps are simulated for evaluation, ``V`` is
   computed again with those scores (so it is never below the plan's own robustness ``R``) and
   reported as ``PlanResult.bound``: ``{"robustness_upper": V, "confidence", "gap": 1 - R / V,
   "scope", "note"}`` (``rap.plan.search.scores.report``); its time and CNN batches are in the
   stats (``bound_seconds``), not in ``seconds``.

Variants measured not to pay (per-assembly score correction, sequential tests, scoring the whole
graph eagerly) live in ``research/variants/`` with their results (docs/RESULTS.md,
research/README.md).

With a perfect model (predictions equal to the simulator's scores) the exact mode returns the
optimum exactly; with zero-width bounds too (``ScoreBounds.zero_width()``), ``V`` is the optimum. Each step of the plan says where its score came from: ``sim`` or ``cnn``.

Cost: one CNN batch per subassembly visited (exact; on held-out assemblies 65-71% of the graph's
operations on average) or per round's candidates (beam), plus the simulations asked for, plus the
bound's dynamic programme (``max_value``: the subassemblies it visits that the search did not are
scored by the CNN; none when the bounds are uncalibrated). No ray, no torch.
"""

from __future__ import annotations

import heapq
import math
import threading
import time
from dataclasses import dataclass

from rap.model.calibration import ScoreBounds, load
from rap.plan.dp import SLACK, dp_choice_bounded, max_value
from rap.plan.search.options import SearchOptions
from rap.plan.search.scores import SearchScores, incumbent, report
from rap.plan.graph import Interlocked, TooLarge, assembly_order, dead_end, reachable
from rap.plan.planners.base import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStep
from rap.stats import bonferroni
from rap.plan.scoring.scorer import Scorer

__all__ = ["SearchPlanner"]

_CURRENT = threading.local()  # .run: the _Run of the search solving in this thread


@dataclass
class _Run:
    """What one search leaves for its plan's bound: the scores, and the graph (exact) or the
    final beam's sequences."""

    scores: SearchScores
    graph: dict | None = None
    beam: list | None = None


class SearchPlanner(Planner):
    """See the module doc. ``SearchOptions`` declares the options, their ranges and the shipped
    defaults: ``SearchPlanner()`` is the shipped search. ``bounds``: the score bounds (None:
    ``rap.model.calibration.load()``, the shipped calibration, read on first use)."""

    name = "search"
    options_class = SearchOptions

    def __init__(self, options: SearchOptions | None = None, *, bounds: ScoreBounds | None = None,
                 **changes):
        if "gap" in changes and changes["gap"] is None:
            changes["gap"] = 0.0  # None or 0: off
        super().__init__(options, **changes)
        self.gap = self.gap or None
        self.bounds = bounds

    def solve(self, problem: PlanningProblem, scorer: Scorer) -> PlanResult:
        """``Planner.solve``, then the plan's bound (module doc, 6)."""
        _CURRENT.run = None
        result = super().solve(problem, scorer)
        run, _CURRENT.run = _CURRENT.run, None
        if not result.found or run is None:
            return result
        t = time.perf_counter()
        before = scorer.stats.to_dict()
        bound = self._bound(run, result)
        stats = dict(result.stats)
        for k, v in scorer.stats.to_dict().items():  # the bound's CNN batches count too
            stats[k] = stats.get(k, 0) + v - before[k]
        stats["bound_seconds"] = time.perf_counter() - t
        return result.with_(bound=bound, stats=stats)

    def _to_simulate(self, scores: SearchScores, ops) -> list:
        """The operations of a chosen sequence still worth a simulation: not simulated, and not
        trusted (predicted score below ``trust``); with bounds, the most raised first."""
        key, trust = scores.key, scores.trust
        todo = [op for op in ops if key(op) not in scores.simulated
                and (trust is None or scores.predicted[key(op)] < trust)]
        if scores.upper:
            todo.sort(key=lambda op: -scores.of(op) / max(scores.known(op), 1e-300))
        return todo

    def _batch(self, scores: SearchScores, todo: list, spent: int) -> list:
        """This round's simulations: ``bound_round`` of ``todo`` while choosing by bounds, else all
        of it; never past the budget."""
        if scores.upper:
            todo = todo[:self.bound_round]
        return todo[:max(0, math.ceil(self.simulations - spent))]

    def _simulate(self, scores: SearchScores, todo: list, chosen, best) -> float:
        """Simulate ``todo`` (steps of the choice ``chosen``; ``best()``: the incumbent's
        robustness, for a variant that simulates against it); returns the simulations spent."""
        scores.simulate(todo)
        return len(todo)

    def _free_bound(self, scores: SearchScores) -> bool:
        """Whether the choosing scores are the upper bounds themselves (the DP's value is V)."""
        return scores.upper == 1.0 and not scores.optimism and scores.trust is None

    def _watching(self, scores: SearchScores) -> bool:
        """Whether each round compares the incumbent with the bound: with ``gap``, or when the
        bound comes free with the choice."""
        if not self.simulations:  # nothing simulated, no incumbent: the bound cannot stop it
            return False
        return self.gap is not None or self._free_bound(scores)

    def _settled(self, best: float, value: float, spent: int, stats: dict) -> bool:
        """Whether the incumbent ``best`` stops the search against the bound ``value``."""
        if best <= 0.0:
            return False
        if best >= value * SLACK:  # nothing left can beat it (the stronger claim first)
            stats["stopped"] = "bound"
        elif self.gap is not None and best >= (1.0 - self.gap) * value:
            stats.update(stopped="gap", gap=self.gap)
        else:
            return False
        stats.update(search_bound=value, stopped_after=spent, predicted_robustness=best)
        return True

    def _second_phase(self, scores: SearchScores, choice: dict, spent: int, stats: dict):
        """When the choice is settled short of ``gap`` with budget left: phase 2 (module doc, 5)
        starts, choosing by the bounds themselves; returns what it must never fall below (the
        settled choice and its robustness by known scores), or None when it does not start."""
        if not (self.gap is not None and spent < self.simulations):
            return None
        scores.by_bounds()
        stats.update(phase1_simulations=spent, gap=self.gap)
        return choice, math.prod(scores.known(op) for op in choice.values())

    @staticmethod
    def _kept(scores: SearchScores, plan: dict | None, floor: tuple, spent: int,
              stats: dict) -> dict:
        """Phase 2's plan: ``plan`` (the incumbent, fully simulated) unless phase 1's settled
        choice (``floor``) is better by known scores (only when it has trusted operations)."""
        r = 0.0 if plan is None else math.prod(scores.known(op) for op in plan.values())
        if r < floor[1]:
            plan, r = floor
        stats.update(phase2_simulations=spent - stats["phase1_simulations"],
                     predicted_robustness=r)
        return plan

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        if len(whole) < 2:
            return []
        if self.bounds is None:
            self.bounds = load()
        raise_ = self.simulations > 0  # raised scores choose what to simulate: none to choose
        scores = SearchScores(problem, scorer, self.bounds,
                              bonferroni(self.confidence, len(whole) - 1),
                              self.optimism if raise_ else 0.0, self.upper if raise_ else 0.0,
                              self.trust)
        try:
            graph = reachable(problem, self.max_operations)
        except TooLarge:
            graph = None
        run = _Run(scores, graph)
        if graph is not None:
            stats["search"] = "exact"
            trees = self._exact(graph, scores, whole, stats)
        else:
            stats["search"] = "beam"
            trees = self._beam(problem, scores, whole, stats, run)
        _CURRENT.run = run
        steps = {}
        for sub, op in trees.items():
            k = scores.key(op)
            steps[sub] = PlanStep.of(op, "sim" if k in scores.simulated else "cnn",
                                     score=scores.simulated.get(k),
                                     confidence=scores.predicted.get(k))
        stats["search_simulations"] = len(scores.simulated)
        stats["predicted_operations"] = len(scores.predicted)
        return assembly_order(steps, whole)

    def _bound(self, run: _Run, result: PlanResult) -> dict:
        """The plan's ``bound`` block with its own simulated scores counted (module doc, 6)."""
        scores = run.scores
        scores.add_simulated([s.to_operation() for s in result.steps],
                             [s.score for s in result.steps])
        if run.graph is not None:
            value, scope = self._max_high(run.graph, scores, scores.problem.whole), "exact"
        else:
            value = max(math.prod(scores.high(op) for op in seq) for seq in run.beam)
            scope = "beam"
        return report(result.robustness, value, self.confidence, scope, scores.bounds,
                      len(result.steps), scores.level)

    @staticmethod
    def _max_high(graph, scores: SearchScores, whole) -> float:
        """``V``: the best product of upper bounds (simulated scores where known)."""
        def scores_of(s):
            if scores.bounds.calibrated:  # uncalibrated: every bound is 1, no CNN needed
                scores.predict(graph[s])
            return scores.scores("high", s, graph[s])

        return max_value(graph, scores_of, whole, scores.memo("high"))

    # -- exact ------------------------------------------------------------------------------------
    def _exact(self, graph, scores: SearchScores, whole, stats) -> dict:
        stats.update(subassemblies=len(graph), operations=sum(len(c) for c in graph.values()))

        def scores_of(s):  # predicted on the first visit, one CNN batch per subassembly
            if not scores.cached("of", s):
                scores.predict(graph[s])
            return scores.scores("of", s, graph[s])

        spent = 0
        floor = None  # phase 2 (module doc, 5): phase 1's settled choice and its robustness
        while True:
            best, tree = dp_choice_bounded(graph, scores_of, whole, scores.memo("of"))
            if best <= 0.0:
                raise Interlocked(dead_end(graph, whole))
            choice = {sub: op for sub, (_, op) in tree.items()}
            if self._watching(scores):
                value = best if self._free_bound(scores) else self._max_high(graph, scores, whole)
                got, tree_got = incumbent(graph, scores, whole)
                if self._settled(got, value, spent, stats):
                    return tree_got if floor is None else self._kept(scores, tree_got, floor,
                                                                     spent, stats)
            todo = self._to_simulate(scores, choice.values())
            if floor is not None and (not todo or spent >= self.simulations):
                stats.update(stopped="budget", search_bound=value, stopped_after=spent)
                return self._kept(scores, tree_got, floor, spent, stats)
            if todo and spent >= self.simulations and scores.raised:
                # budget spent with raised scores still in the choice: choose by what is known
                scores.lower()
                continue
            if not todo and (floor := self._second_phase(scores, choice, spent, stats)):
                continue
            if not todo or spent >= self.simulations:
                stats["predicted_robustness"] = math.prod(scores.known(op)
                                                          for op in choice.values())
                stats["stopped"] = "budget" if todo else "settled"
                return choice
            todo = self._batch(scores, todo, spent)
            spent += self._simulate(scores, todo, choice.values(),
                                    lambda: incumbent(graph, scores, whole)[0])

    # -- beam -------------------------------------------------------------------------------------
    def _beam(self, problem: PlanningProblem, scores: SearchScores, whole, stats,
              run: _Run) -> dict:
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
            if not nxt:  # every state reached a dead end: blame the smallest one seen
                locked = [s for s, c in cands.items() if not c]
                raise Interlocked(min(locked, key=lambda x: (len(x), sorted(x))) if locked
                                  else whole)
            beam = heapq.nlargest(self.beam_width, nxt, key=lambda st: (st[0], -st[1]))
        stats.update(beam_rounds=rounds, beam_width=self.beam_width)
        run.beam = [[op for _, op in st[3]] for st in beam]
        # simulations where they matter: re-rank the final sequences by mixed products
        spent = 0
        floor = None  # phase 2, as in exact mode, over the final beam's sequences
        while True:
            ranked = sorted(beam, key=lambda st: (-sum(math.log(max(scores.of(op), 1e-300))
                                                       for _, op in st[3]), st[1]))
            top = ranked[0][3]
            if self._watching(scores):
                value = max(math.prod(scores.high(op) for op in seq) for seq in run.beam)
                full = [st[3] for st in ranked if all(scores.is_simulated(op) for _, op in st[3])]
                got = max((math.prod(scores.known(op) for _, op in seq), -i)
                          for i, seq in enumerate(full)) if full else (0.0, 0)
                got_plan = dict(full[-got[1]]) if full else None
                if self._settled(got[0], value, spent, stats):
                    return got_plan if floor is None else self._kept(scores, got_plan, floor,
                                                                     spent, stats)
            todo = self._to_simulate(scores, [op for _, op in top])
            if floor is not None and (not todo or spent >= self.simulations):
                stats.update(stopped="budget", search_bound=value, stopped_after=spent)
                return self._kept(scores, got_plan, floor, spent, stats)
            if todo and spent >= self.simulations and scores.raised:
                scores.lower()  # as in exact mode: the budget is spent, rank by what is known
                continue
            if not todo and (floor := self._second_phase(scores, dict(top), spent, stats)):
                continue
            if not todo or spent >= self.simulations:
                stats["predicted_robustness"] = math.prod(scores.known(op) for _, op in top)
                stats["stopped"] = "budget" if todo else "settled"
                return dict(top)
            todo = self._batch(scores, todo, spent)
            spent += self._simulate(scores, todo, [op for _, op in top], lambda: max(
                (math.prod(scores.known(op) for _, op in st[3]) for st in beam
                 if all(scores.is_simulated(op) for _, op in st[3])), default=0.0))


SearchOptions.planner = SearchPlanner
