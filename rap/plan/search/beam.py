"""Beam search over partial decompositions: the search's mode beyond the exact budget.

``beam_states(problem, scores, width)`` decomposes top-down: a state is a partial plan (the
choices made so far and the subassemblies still open, largest first); each round expands every
state's largest open subassembly by each of its candidates and keeps the ``width`` states of
highest product of ``scores.of`` (what the search chooses by: simulated where known, else the
model's raised score). It returns the final, complete states; the search then re-ranks them with
simulations (``rap.plan.search.planner``).

A state: ``(log product, tie-break counter, open subassemblies, ((subassembly, operation), ...))``.
Ties go to the state made first. An interlock that ends every state raises ``Interlocked`` naming
the smallest dead end seen (a minimal one is named later by ``rap.plan.interlocked``).

``BeamMode`` is the search's beam mode, a part of ``rap.plan.search.planner.SearchPlanner`` (a
mixin, with ``rap.plan.search.refine.RefineLoop``): ``_beam(run)`` (the search's run state,
``rap.plan.search.run.SearchRun``) takes the final beam, lets greedy's plan (``run.start``) join
it, keeps its sequences as ``run.beam``, and refines the choice among its sequences (re-ranked by mixed products) with
simulations; then, with budget left, the plan's runs of one-part steps are re-ordered ``window``
steps at a time (``rap.plan.search.windows.polish``). ``V`` and the incumbent range over the final
beam's sequences only (``_beam_value``; the bound's scope ``beam``).

Cost: one scorer batch per round (the candidates of the states' largest open subassemblies), at
most ``n - 1`` rounds for ``n`` parts, ``width`` x candidates states a round; then the refine
loop's and the windows' simulations. No ray, no torch.
"""

from __future__ import annotations

import heapq
import math

from rap.plan.graph import Interlocked
from rap.plan.problem import PlanningProblem
from rap.plan.search.run import SearchRun
from rap.plan.search.scores import SearchScores
from rap.plan.search.windows import polish

__all__ = ["BeamMode", "beam_states", "log_product"]


def log_product(scores, choices) -> float:
    """The log of the product of ``scores.of`` over a state's ``(subassembly, operation)``
    choices (a zero score counts as 1e-300)."""
    return sum(math.log(max(scores.of(op), 1e-300)) for _, op in choices)


def beam_states(problem: PlanningProblem, scores, width: int) -> tuple[list, int]:
    """The final beam (complete states, module doc) and the number of rounds."""
    whole = problem.whole
    beam = [(0.0, 0, (whole,), ())]
    counter = 1
    rounds = 0
    while any(st[2] for st in beam):
        rounds += 1
        expand = [st for st in beam if st[2]]
        nxt = [st for st in beam if not st[2]]
        cands = {}
        for _, _, open_, _ in expand:
            if open_[0] not in cands:
                cands[open_[0]] = problem.candidates(open_[0])
        scores.predict([op for c in cands.values() for op in c])
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
        beam = heapq.nlargest(width, nxt, key=lambda st: (st[0], -st[1]))
    return beam, rounds


class BeamMode:
    """The beam mode (module doc); mixed into ``SearchPlanner``."""

    def _beam(self, run: SearchRun) -> dict:
        problem, scores, stats = run.problem, run.scores, run.stats
        first = run.start.sequence if run.start is not None else ()
        beam, rounds = beam_states(problem, scores, self.beam_width)
        stats.update(beam_rounds=rounds, beam_width=self.beam_width)
        if first and all(st[3] != first for st in beam):  # greedy's plan competes (planner doc, 2)
            beam.append((log_product(scores, first), max(st[1] for st in beam) + 1, (), first))
        run.beam = [[op for _, op in st[3]] for st in beam]
        # simulations where they matter: re-rank the final sequences by mixed products
        ranked: list = []

        def choose():
            ranked[:] = sorted(beam, key=lambda st: (-log_product(scores, st[3]), st[1]))
            return dict(ranked[0][3]), None

        def incumbent_of():
            full = [st[3] for st in ranked if all(scores.is_simulated(op) for _, op in st[3])]
            if not full:
                return 0.0, None
            got = max((math.prod(scores.known(op) for _, op in seq), -i)
                      for i, seq in enumerate(full))
            return got[0], dict(full[-got[1]])

        plan = self._refine(run, choose, lambda _: self._beam_value(run), incumbent_of)
        left = run.budget - run.refined
        if self.window and left > 0 and len(plan) == len(problem.whole) - 1:
            deadline = (scores.scorer.started + self.time_limit) if self.time_limit else None
            plan = polish(problem, scores, plan, self.window, left, stats, deadline)
            run.beam.append(list(plan.values()))  # the bound's scope covers the polished plan
        return plan

    @staticmethod
    def _beam_value(run: SearchRun) -> float:
        """``V`` over the final beam's sequences only (the bound's scope ``beam``)."""
        return max(math.prod(run.scores.high(op) for op in seq) for seq in run.beam)
