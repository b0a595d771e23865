"""Random sequences: the baseline of the paper's tables.

``RandomPlanner`` draws ``samples`` sequences, each split chosen uniformly among the candidates,
seeded from the root seed and the problem's content (``rap.seeds.derive_rng``);
``stats["mean_robustness"]`` is the baseline figure, and the returned sequence is the sample whose
robustness is closest to that mean. ``random_sequence(problem, rng)`` is one such draw (also used
by research/choice_breadth.py). Cost: ``samples`` x the steps' simulations. No ray, no torch.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from rap.plan.graph import Interlocked, assembly_order
from rap.plan.planners.base import Planner
from rap.plan.planners.options import PlannerOptions, option
from rap.plan.report.result import PlanStep
from rap.seeds import derive_rng

__all__ = ["RandomPlanner", "RandomOptions", "random_sequence"]


def random_sequence(problem, rng: np.random.Generator) -> list[PlanStep]:
    """One sequence of uniform splits: from the whole assembly, each subassembly's operation
    drawn uniformly among its candidates with ``rng`` (its fixed part, then its moving part, split
    next), the steps (source ``random``) in assembly order. Raises ``Interlocked`` at a
    subassembly with no candidate. Cost: the candidates of the subassemblies visited."""
    choice: dict[frozenset, PlanStep] = {}
    stack = [problem.whole]
    while stack:
        s = stack.pop()
        c = problem.candidates(s)
        if not c:
            raise Interlocked(s)
        op = c[int(rng.integers(len(c)))]
        choice[s] = PlanStep.of(op, "random")
        stack += [x for x in (op.fixed, op.moving) if len(x) >= 2]
    return assembly_order(choice, problem.whole)


@dataclass(frozen=True)
class RandomOptions(PlannerOptions):
    """Random sequences, the sample closest to their mean robustness (``RandomPlanner``)."""

    method: ClassVar[str] = "random"

    samples: int = option(int, 50, low=1, service=False,
                          help="Random sequences (method {method})")


class RandomPlanner(Planner):
    """``samples`` (``RandomOptions``, default 50) random sequences
    (uniform split at each subassembly); see module doc."""

    name = "random"
    options_class = RandomOptions

    def _search(self, problem, scorer, stats):
        key = hashlib.sha256(f"random-sequences|{problem.geometry_hash}|{problem.space}".encode()).hexdigest()
        rng = derive_rng(problem.root_seed, key)
        orders = [random_sequence(problem, rng) for _ in range(self.samples)]
        flat = [st.to_operation() for o in orders for st in o]
        scores = np.asarray(scorer.scores(problem, flat), dtype=np.float64).reshape(len(orders), -1)
        r = scores.prod(axis=1)
        mean = float(r.mean())
        pick = int(np.argmin(np.abs(r - mean)))
        stats.update(samples=self.samples, mean_robustness=mean, std_robustness=float(r.std()),
                     min_robustness=float(r.min()), max_robustness=float(r.max()),
                     distinct_sequences=len({tuple(st.to_operation().key("") for st in o) for o in orders}))
        return orders[pick]


RandomOptions.planner = RandomPlanner
