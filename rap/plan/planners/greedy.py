"""The greedy planners: RAP (the paper's Algorithm 1 with the CNN) and simulator-only greedy.

Assembly-by-disassembly, one level at a time: every open subassembly of a level is split by one of
its candidates, chosen at once (their choices are independent: one CNN batch and one simulator
batch per level, run in parallel by a pooled backend, give the same plan as the recursion).

* ``SimPlanner`` (``SimOptions``): every candidate simulated, the best taken.
* ``RapPlanner`` (``RapOptions``): among the candidates predicted *high* (P(high) >=
  ``high_probability``) the most confident; when none is, a simulator fallback (class doc).

Ties go to the first candidate in ``problem.candidates`` order. No ray, no torch.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar, Sequence

from rap.operation import Operation
from rap.plan.dp import argmax_first
from rap.plan.graph import Interlocked, assembly_order
from rap.plan.planners.base import HIGH_PROBABILITY, Planner
from rap.plan.planners.options import PlannerOptions, option
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStep
from rap.plan.scoring.scorer import BudgetSpent, ScorerProtocol

__all__ = ["SimPlanner", "RapPlanner", "SimOptions", "RapOptions", "PAPER_RAP",
           "RAP_HIGH_PROBABILITY", "RAP_FALLBACK_OPTIMISM", "FALLBACK_ROUND"]

#: candidates of one subassembly simulated per round of RAP's best-first fallback: two keep two
#: simulation workers busy at the top of the tree, where one subassembly is open
FALLBACK_ROUND = 2
# RAP's defaults: a candidate is taken without simulation at P(high) >= 0.9, and the fallback
# simulates best first with optimism 0.4. Chosen on ten fresh assemblies no model was trained on
# (research/rap_validation.py --set fresh): 0.047 more robust than the paper's rule (P(high) >= 0.5,
# every candidate simulated) for 9% more simulations; on the twelve unseen test assemblies within
# 0.006 of simulator-only greedy (the paper's rule: 0.046 below it). docs/RESULTS.md, "RAP's
# decision rule".
RAP_HIGH_PROBABILITY = 0.9
RAP_FALLBACK_OPTIMISM = 0.4
PAPER_RAP = {"high_probability": HIGH_PROBABILITY, "fallback_optimism": 1.0}  # the paper's rule


@dataclass(frozen=True)
class RapOptions(PlannerOptions):
    """RAP, the paper's Algorithm 1 with the CNN (``RapPlanner``)."""

    method: ClassVar[str] = "rap"
    needs_model: ClassVar[bool] = True
    summary: ClassVar[str] = "the paper's greedy planner"
    presets: ClassVar[dict] = {"paper": PAPER_RAP}

    fallback_k: int | None = option(
        int, None, low=1, code="k", code_name="K",
        help="Method {method}: when no candidate is predicted high, simulate at most the K most "
             "likely", default_help="every candidate, until one is good enough")
    high_probability: float = option(
        float, RAP_HIGH_PROBABILITY, low=0.0, high=1.0, low_open=True, noun="a probability",
        code="p", code_name="P", percent=True, default_help="the paper: 0.5",
        help="Method {method}: a candidate is taken without simulation at P(high) >= this")
    fallback_optimism: float = option(
        float, RAP_FALLBACK_OPTIMISM, low=0.0, high=1.0, code="o", code_name="U", percent=True,
        help="Method {method}: the fallback simulates candidates best first until the best "
             "simulated score exceeds the next one's p + U (1 - p), p its expected score (1: all "
             "at once, the paper's rule with {high_probability} 0.5)")


@dataclass(frozen=True)
class SimOptions(PlannerOptions):
    """Simulator-only greedy: every candidate simulated, the best taken (``SimPlanner``)."""

    method: ClassVar[str] = "sim"


class _Greedy(Planner):
    """Greedy assembly-by-disassembly, one level of open subassemblies at a time. ``finish``
    (None: off): when a level's choice spends the scorer's budget (``BudgetSpent``), ``finish(
    problem, scorer, cands, stats)`` chooses that level and every later one instead (an anytime
    greedy: a complete plan whenever the budget ends; ``stats["finished_levels"]``)."""

    finish = None

    @abc.abstractmethod
    def _select(self, problem: PlanningProblem, scorer: ScorerProtocol,
                cands: list[tuple[Operation, ...]], stats: dict) -> list[PlanStep]:
        """One chosen step per open subassembly, given each one's candidate operations."""

    def _search(self, problem, scorer, stats):
        whole = problem.whole
        choice: dict[frozenset, PlanStep] = {}
        open_ = [whole] if len(whole) >= 2 else []
        stats.update(levels=0, decisions=0)
        finishing = False  # the budget ended: ``finish`` chooses this level and every later one
        while open_:
            cands = []
            for s in open_:
                c = problem.candidates(s)
                if not c:
                    raise Interlocked(s)
                cands.append(c)
            if not finishing:
                try:
                    chosen = self._select(problem, scorer, cands, stats)
                except BudgetSpent:
                    if self.finish is None:
                        raise
                    finishing = True
            if finishing:
                chosen = self.finish(problem, scorer, cands, stats)
                stats["finished_levels"] = stats.get("finished_levels", 0) + 1
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
    options_class = SimOptions

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

    ``fallback_optimism = 1`` never stops early: every candidate (or the ``fallback_k`` most
    confident) is simulated in one batch, the paper's rule with ``high_probability = 0.5``
    (``RapPlanner(**PAPER_RAP)``). ``RapOptions`` declares the options, their ranges and the
    defaults chosen on held-out assemblies: ``RapPlanner()`` is the shipped method.
    """

    name = "rap"
    options_class = RapOptions

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
                out[k] = PlanStep.of(c[i], "model", confidence=p[i])
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


RapOptions.planner = RapPlanner
SimOptions.planner = SimPlanner
