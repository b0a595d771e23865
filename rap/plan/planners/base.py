"""Assembly-sequence planners: RAP, the simulator-only greedy baseline, the optimum, random.

Every planner takes a ``PlanningProblem`` and a ``Scorer`` and returns a ``PlanResult`` (OMPL's
``Planner::solve(ProblemDefinition) -> PlannerStatus``). Plans are found by assembly-by-disassembly:
a subassembly ``S`` is split by one of ``problem.candidates(S)`` into a moving and a fixed
subassembly, and both sides are planned the same way down to single parts. The returned steps are in
assembly order (children before parents: the disassembly sequence reversed).

* ``RapPlanner`` (the paper's Algorithm 1 with the CNN scorer): the CNN scores every candidate of
  ``S`` in one batch; among those predicted *high* (P(high) >= ``high_probability``: the paper's
  0.5; ``rap.plan.methods`` defaults to 0.9) the most confident is taken; when none is, the
  candidates are simulated and the best taken (a *fallback*): all of them (the paper's rule),
  at most the ``fallback_k`` with the highest P(high), or best first until no unsimulated
  candidate is expected to beat the best simulated one (``fallback_optimism`` < 1).
* ``SimPlanner``: every candidate is simulated; the best is taken.
* ``OptimalPlanner``: the most robust sequence over the same operation space, maximising the product
  of simulated scores by dynamic programming over subassemblies:
  ``best(S) = max over (M, F, d) of r(op) * best(M) * best(F)``, ``best({p}) = 1``. Each reachable
  subassembly and each operation is visited once, against the paper's exhaustive search over every
  sequence (``stats["exhaustive_sequences"]`` counts the assembly trees it would enumerate).
  The graph, its dynamic programme and the ``Interlocked`` error live in ``rap.plan.graph``.
* ``RandomPlanner``: ``samples`` (50) random sequences, each split chosen uniformly among the
  candidates, seeded from the root seed; ``stats["mean_robustness"]`` is the baseline figure and the
  returned sequence is the sample whose robustness is closest to that mean.

The greedy planners decide all open subassemblies of one level together: their choices are
independent of each other, so batching them (one CNN batch, one simulator batch per level, run in
parallel by a pooled backend) gives the same plan as the recursive formulation with fewer calls.

Ties go to the first candidate in ``problem.candidates`` order (deterministic). Every returned
sequence is evaluated by the simulator (``PlanResult.robustness`` = product of step scores).

No ray, no torch.
"""

from __future__ import annotations

import abc
import hashlib
import math
import time
from typing import Sequence

import numpy as np

from rap.operation import Operation
from rap.plan.dp import argmax_first, dp_choice, dp_tree
from rap.plan.graph import Interlocked, assembly_order, dead_end, reachable
from rap.plan.report.poses import annotate_plan
from rap.plan.cell.rules import blocked_by, constraint_stats
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult, PlanStatus, PlanStep
from rap.plan.scoring.scorer import Budget, BudgetSpent, Scorer
from rap.seeds import derive_rng

__all__ = ["Planner", "RapPlanner", "SimPlanner", "OptimalPlanner", "RandomPlanner",
           "evaluate_steps", "HIGH_PROBABILITY", "FALLBACK_ROUND"]

HIGH_PROBABILITY = 0.5  # the CNN's class decision: P(high) >= 0.5 is "high"
#: candidates of one subassembly simulated per round of RAP's best-first fallback: two keep two
#: simulation workers busy at the top of the tree, where one subassembly is open
FALLBACK_ROUND = 2


def evaluate_steps(problem: PlanningProblem, scorer: Scorer,
                   steps: Sequence[PlanStep]) -> list[PlanStep]:
    """The steps with their simulator scores (one batch; cached scores reused)."""
    scores = scorer.scores(problem, [s.to_operation() for s in steps])
    return [PlanStep(s.moving, s.fixed, s.direction, s.source, sc, s.confidence, s.operation)
            for s, sc in zip(steps, scores)]


class Planner(abc.ABC):
    """Base class: ``solve(problem, scorer) -> PlanResult``; subclasses implement ``_search``."""

    name: str = ""

    def solve(self, problem: PlanningProblem, scorer: Scorer) -> PlanResult:
        t0 = time.perf_counter()
        scorer.started = t0
        stats: dict = {}
        base = scorer.stats.to_dict()

        def counters() -> dict:
            now = scorer.stats.to_dict()
            return {k: now[k] - base[k] for k in now}

        stats.update(constraint_stats(problem))  # the cell's constraints, the scores' scope
        try:
            steps = self._search(problem, scorer, stats)
        except Interlocked as exc:
            culprit, message = blocked_by(problem, exc.subset)  # an interlock or a constraint
            return PlanResult(PlanStatus.INFEASIBLE, self.name, problem.assembly.name,
                              seconds=time.perf_counter() - t0,
                              interlocked=tuple(sorted(culprit)),
                              stats={**stats, **counters(),
                                     "stuck_at": sorted(exc.subset), "blocked": message},
                              message=message)
        except BudgetSpent as exc:
            return PlanResult(PlanStatus.BUDGET_SPENT, self.name, problem.assembly.name,
                              seconds=time.perf_counter() - t0,
                              stats={**stats, **counters()}, message=str(exc))
        seconds = time.perf_counter() - t0
        t1 = time.perf_counter()
        before = scorer.stats.sim_run
        saved, scorer.budget = scorer.budget, Budget()  # evaluation is not part of the search
        try:
            steps = evaluate_steps(problem, scorer, steps)
        finally:
            scorer.budget = saved
        eval_seconds = time.perf_counter() - t1
        stats["eval_simulations"] = scorer.stats.sim_run - before
        robustness = float(math.prod(s.score for s in steps))  # type: ignore[misc]
        # what a controller and a user read: poses, intervals, reasons (rap.plan.report.poses)
        return annotate_plan(PlanResult(PlanStatus.FOUND, self.name, problem.assembly.name,
                                        tuple(steps), robustness, seconds, eval_seconds,
                                        stats={**stats, **counters()}), problem)

    @abc.abstractmethod
    def _search(self, problem: PlanningProblem, scorer: Scorer, stats: dict) -> list[PlanStep]:
        """The steps in assembly order (scores filled in later), or raise ``Interlocked``."""


class _Greedy(Planner):
    """Greedy assembly-by-disassembly, one level of open subassemblies at a time."""

    @abc.abstractmethod
    def _select(self, problem: PlanningProblem, scorer: Scorer,
                cands: list[tuple[Operation, ...]], stats: dict) -> list[PlanStep]:
        """One chosen step per open subassembly, given each one's candidate operations."""

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        choice: dict[frozenset, PlanStep] = {}
        open_ = [whole] if len(whole) >= 2 else []
        stats.update(levels=0, decisions=0)
        while open_:
            cands = []
            for s in open_:
                c = problem.candidates(s)
                if not c:
                    raise Interlocked(s)
                cands.append(c)
            chosen = self._select(problem, scorer, cands, stats)
            stats["levels"] += 1
            stats["decisions"] += len(open_)
            nxt = []
            for s, st in zip(open_, chosen):
                choice[s] = st
                nxt += [side for side in (frozenset(st.moving), frozenset(st.fixed)) if len(side) >= 2]
            open_ = nxt
        return assembly_order(choice, whole)


def _split(flat: Sequence, cands: list[tuple]) -> list[list]:
    out, i = [], 0
    for c in cands:
        out.append(list(flat[i:i + len(c)]))
        i += len(c)
    return out


class SimPlanner(_Greedy):
    """The simulator-only greedy baseline: simulate every candidate, take the best."""

    name = "sim"

    def _select(self, problem, scorer, cands, stats):
        flat = [op for c in cands for op in c]
        scores = _split(scorer.scores(problem, flat), cands)
        out = []
        for c, sc in zip(cands, scores):
            i = argmax_first(sc)
            out.append(PlanStep.of(c[i], "sim", score=sc[i]))
        return out


class RapPlanner(_Greedy):
    """RAP: the CNN's most confident *high* candidate, else a simulator fallback (module doc).

    Confidence is P(high), ties (P(high) saturates at 1.0 in float32 for near-certain candidates)
    broken by the expected score, then by candidate order. A subassembly none of whose candidates
    reaches ``high_probability`` falls back on the simulator, best first: its candidates are
    simulated in order of confidence (at most ``fallback_k`` of them; None: all),
    ``FALLBACK_ROUND`` per subassembly per round (one batch for every open fallback of the level),
    until the best simulated score exceeds the next candidate's optimistic bound
    ``p + fallback_optimism (1 - p)``, ``p`` its expected score (no unsimulated candidate is then
    expected to beat it); the best simulated candidate is taken.

    ``fallback_optimism = 1`` (the default) never stops early: every candidate (or the
    ``fallback_k`` most confident) is simulated in one batch, the paper's rule with
    ``high_probability = 0.5``. ``rap.plan.methods.RapOptions`` declares the options (ranges,
    and the defaults chosen on held-out assemblies) and checks them; they are not checked here.
    """

    name = "rap"

    def __init__(self, high_probability: float = HIGH_PROBABILITY, fallback_k: int | None = None,
                 fallback_optimism: float = 1.0):
        self.high_probability = float(high_probability)
        self.fallback_k = fallback_k
        self.fallback_optimism = float(fallback_optimism)

    def _select(self, problem, scorer, cands, stats):
        flat = [op for c in cands for op in c]
        ph, ex = scorer.prob_high_and_expected(problem, flat)
        probs, expected = _split(ph, cands), _split(ex, cands)
        out: list[PlanStep | None] = [None] * len(cands)
        fallback = []
        for k, (c, p, e) in enumerate(zip(cands, probs, expected)):
            high = [i for i, v in enumerate(p) if v >= self.high_probability]
            if high:
                i = max(high, key=lambda j: (p[j], e[j], -j))
                out[k] = PlanStep.of(c[i], "cnn", confidence=p[i])
            else:
                fallback.append(k)
        stats["fallbacks"] = stats.get("fallbacks", 0) + len(fallback)
        stats.setdefault("fallback_candidates", 0)
        if fallback:
            simulated = self._fallback(problem, scorer, cands, probs, expected, fallback, stats)
            for k in fallback:
                sc = simulated[k]
                i = max(sc, key=lambda j: (sc[j], -j))  # the best; ties: candidate order
                out[k] = PlanStep.of(cands[k][i], "sim", score=sc[i])
        return out  # type: ignore[return-value]

    def _fallback(self, problem, scorer, cands, probs, expected, fallback, stats) -> dict:
        """The best-first fallback (class doc): ``{k: {candidate index: simulated score}}``."""
        u = self.fallback_optimism
        per_round = FALLBACK_ROUND if u < 1.0 else None  # u = 1: nothing stops it, one batch
        todo = {}
        for k in fallback:
            order = sorted(range(len(cands[k])), key=lambda j: (-probs[k][j], -expected[k][j], j))
            todo[k] = order if self.fallback_k is None else order[:self.fallback_k]
        simulated: dict[int, dict[int, float]] = {k: {} for k in fallback}
        active = list(fallback)
        while active:
            batch = []
            for k in active:
                take = todo[k][:per_round]
                todo[k] = todo[k][len(take):]
                batch += [(k, j) for j in take]
            stats["fallback_candidates"] += len(batch)
            for (k, j), sc in zip(batch, scorer.scores(problem, [cands[k][j] for k, j in batch])):
                simulated[k][j] = sc
            active = [k for k in active if todo[k] and max(simulated[k].values())
                      <= expected[k][todo[k][0]] + u * (1.0 - expected[k][todo[k][0]])]
        return simulated


class OptimalPlanner(Planner):
    """The most robust sequence over the operation space, by dynamic programming (module doc)."""

    name = "optimal"

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        if len(whole) < 2:
            return []
        graph = reachable(problem)
        if not graph[whole]:
            raise Interlocked(whole)
        flat = [op for c in graph.values() for op in c]
        scores = iter(scorer.scores(problem, flat))
        score_of = {s: [next(scores) for _ in c] for s, c in graph.items()}
        best, arg = dp_choice(graph, score_of)
        if best[whole] <= 0.0:
            raise Interlocked(dead_end(graph, whole))
        trees: dict[frozenset, int] = {}

        def t(x):
            return trees.get(x, 0) if len(x) >= 2 else 1

        for s in sorted(graph, key=len):
            trees[s] = sum(t(op.moving) * t(op.fixed) for op in graph[s])
        choice = {sub: PlanStep.of(op, "sim", score=score_of[sub][i])
                  for sub, (i, op) in dp_tree(graph, arg, whole).items()}
        n_ex = trees[whole]
        terms = len(flat)
        stats.update(subassemblies=len(graph), operations=len(flat), dp_evaluations=terms,
                     exhaustive_sequences=n_ex,
                     exhaustive_step_evaluations=n_ex * (len(whole) - 1),
                     dp_speedup=n_ex * (len(whole) - 1) / max(1, terms),
                     predicted_robustness=best[whole])
        return assembly_order(choice, whole)


class RandomPlanner(Planner):
    """``samples`` (>= 1, checked by ``rap.plan.methods.RandomOptions``) random sequences
    (uniform split at each subassembly); see module doc."""

    name = "random"

    def __init__(self, samples: int = 50):
        self.samples = int(samples)

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        if len(whole) < 2:
            return []
        key = hashlib.sha256(f"random-sequences|{problem.geometry_hash}|{problem.space}".encode()).hexdigest()
        rng = derive_rng(problem.root_seed, key)
        sequences: list[dict[frozenset, PlanStep]] = []
        for _ in range(self.samples):
            choice: dict[frozenset, PlanStep] = {}
            stack = [whole]
            while stack:
                s = stack.pop()
                c = problem.candidates(s)
                if not c:
                    raise Interlocked(s)
                op = c[int(rng.integers(len(c)))]
                choice[s] = PlanStep.of(op, "random")
                stack += [x for x in (op.fixed, op.moving) if len(x) >= 2]
            sequences.append(choice)
        orders = [assembly_order(ch, whole) for ch in sequences]
        flat = [st.to_operation() for o in orders for st in o]
        scores = np.asarray(scorer.scores(problem, flat), dtype=np.float64).reshape(len(orders), -1)
        r = scores.prod(axis=1)
        mean = float(r.mean())
        pick = int(np.argmin(np.abs(r - mean)))
        stats.update(samples=self.samples, mean_robustness=mean, std_robustness=float(r.std()),
                     min_robustness=float(r.min()), max_robustness=float(r.max()),
                     distinct_sequences=len({tuple(st.to_operation().key("") for st in o) for o in orders}))
        return orders[pick]
