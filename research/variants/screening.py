"""Sequential tests in the search: simulate an operation only as far as the choice needs.

A search (``rap.plan.search.planner``, ``sequential``) simulates operations of its optimistic choice to
learn whether that choice can beat the *incumbent* ``I`` (its best fully simulated sequence). The
choice, with every other step at the score it is chosen by (``SearchScores.of``), beats ``I`` only
if the operation's score is at least ``tau = I / (product of the choice's other steps' scores)``
(``thresholds``); the choice is the best product among all sequences holding the operation, so no
sequence holding it can do better at those scores. ``screen`` runs each operation's sequential
test (``research.variants.sequential.SequentialTest``: chunks of trials, e.g. 20, 20, 20) against its
``tau``:

* shown ``below`` ``tau`` at the test's error rate: the operation is left *partly simulated*
  (``SearchScores.add_partial``: its chunks' rate and upper bound), which takes the choice off
  it; when a later choice holds it again, its next chunk is run against the new ``tau``;
* shown ``above``, undecided after the last chunk, or undecided with its rate so far at least
  ``tau`` (more chunks would rarely show it below: they would only add to the label's trials):
  it gets its fixed full simulation (the label: ``Scorer.scores``, cached), as without the test.

An operation is simulated in full at once (no chunk) when there is no threshold (``I = 0``: no
incumbent yet) or when the scorer's backend runs no chunks (the farm's pool: ``Scorer.chunked``).
A label already cached is not used in place of the chunks, so that the plan does not depend on
what the cache holds (as without the test). Chunks are never cached and never a step's score: a
plan's steps are evaluated with their labels (``rap.plan.planners.base.Planner.solve``).

Cost: one backend call per chunk round (the operations still under test together) and one for the
full simulations; ``screen`` returns what it spent in full simulations, cached or not, as the
search counts them: one per full simulation, ``trials / params.trials`` per chunk. No ray, no
torch.
"""

from __future__ import annotations

import math
from typing import Sequence

from rap.operation import Operation
from rap.plan.search.scores import SearchScores
from research.variants.sequential import ABOVE, BELOW, SequentialTest

__all__ = ["thresholds", "screen"]


def thresholds(scores: SearchScores, chosen: Sequence[Operation], ops: Sequence[Operation],
               best: float) -> list[float]:
    """``tau`` of each of ``ops`` (steps of the choice ``chosen``) against the incumbent's
    robustness ``best``: ``best / product of the other steps' scores`` (0 when ``best`` is 0)."""
    chosen = list(chosen)
    out = []
    for op in ops:
        if best <= 0.0:
            out.append(0.0)
            continue
        others = math.prod(scores.of(o) for o in chosen if o is not op)
        out.append(best / others if others > 0.0 else math.inf)
    return out


def screen(scores: SearchScores, ops: Sequence[Operation], taus: Sequence[float],
           test: SequentialTest) -> float:
    """Run the sequential test of each of ``ops`` against its ``tau`` (module doc); returns the
    simulations spent (a chunk counting ``trials / params.trials``)."""
    scorer, problem = scores.scorer, scores.problem
    per_full = problem.params.trials
    full: list[Operation] = []
    under: list[list] = []  # [op, tau, successes, trials]
    for op, tau in zip(ops, taus):
        k = scores.key(op)
        if k in scores.simulated:
            continue
        if tau <= 0.0 or not scorer.chunked:
            full.append(op)
            continue
        s, n, _ = scores.partial.get(k, (0, 0, 1.0))
        under.append([op, tau, s, n])
    spent = 0.0
    last = test.looks[-1]
    while under:
        ask = []
        for item in under:
            op, tau, s, n = item
            if n and (n == last or s >= tau * n or test.decide(s, n, tau) == ABOVE):
                # decided above, not below by the last look, or unlikely to be shown below (its
                # rate so far at least tau): the label decides
                full.append(op)
            else:
                ask.append(item)
        if not ask:
            break
        index = [test.looks.index(n) + 1 if n else 0 for _, _, _, n in ask]
        got = scorer.chunks(problem, [(item[0], i, test.chunks[i])
                                      for item, i in zip(ask, index)])
        under = []
        for item, c in zip(ask, got):
            item[2] += c.successes
            item[3] += c.trials
            spent += c.trials / per_full
            op, tau, s, n = item
            if test.decide(s, n, tau) == BELOW:
                scores.add_partial(op, s, n, test.upper(s, n))
            else:
                under.append(item)
    if full:
        scores.simulate(full)
    return spent + len(full)
