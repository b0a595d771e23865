"""What a planner returns: a status, the steps in assembly order, and what it cost.

``PlanStatus`` (like OMPL's ``PlannerStatus``): ``FOUND``, ``INFEASIBLE`` (some subassembly admits
no one-step translation: ``interlocked`` names it), ``BUDGET_SPENT`` (the planner stopped at its
budget of simulations or seconds).

``PlanStep``: one assembly operation in assembly order; ``direction`` (also ``insertion``) is the
unit vector along which ``moving`` travels to its place, the *insertion* direction (the NDBG's
removal direction is its opposite); ``score`` the simulator's score of that operation (every
returned sequence is evaluated by the simulator); ``source`` what chose it (``"model"``: the
learned scorer, the default's cascade of trees and CNN or RAP's CNN; ``"sim"``, ``"random"``;
``"free"``: an operation robust by geometry, scored 1 without the simulator or the model,
``PlanningProblem.is_free``); ``confidence`` the model's P(high) where a planner ranked by it
(RAP), else ``None``; ``predicted`` the model's expected score where a planner multiplied it (the
search), else ``None``. Format 3 adds ``execution`` (``rap.plan.report.execution.StepExecution``:
success once reached, clearance, tolerance) per step and ``sequence_success``
(``SequenceReport``) per plan; formats 1 and 2 (whose ``source`` said ``"cnn"`` for ``"model"``)
are read too. Filled in by
``rap.plan.report.poses.annotate_plan``: ``score_interval`` (``rap.plan.report.intervals``),
``reason`` (``rap.plan.report.reasons``) and ``robot`` (a ``RobotMove``: start, approach and goal poses,
travel, in the assembly's units; ``rap.plan.report.poses``).

``PlanResult.to_json()`` is the ``rap-farm plan --out`` document and the body of the planning
service's answer (``rap.serve.http_app``); ``PlanResult.from_json(doc)`` reads it back (what
``rap-farm plan --server`` prints and writes), so ``from_json(doc).to_json() == doc``. A step's
direction is written as ``"insertion"``; documents of earlier versions, with ``"direction"`` and
without the intervals, reasons and robot moves, are read too. The keys are documented in
README.md ("Plan files").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Sequence

from rap.operation import Operation
from rap.plan.interlocked import interlocked_message
from rap.plan.report.execution import SequenceReport, StepExecution
from rap.stats import expected_attempts

__all__ = ["PlanStatus", "PlanStep", "PlanResult", "RobotMove", "SOURCES", "FORMAT",
           "is_assembly_order"]

SOURCES = ("model", "sim", "random", "free")
#: the plan document's format: 3 adds ``sequence_success`` and each step's ``execution`` and
#: ``predicted`` (the search's expected score, which format 2 wrote in ``confidence``) and says
#: ``"model"`` where 2 said ``"cnn"``; 2 names a step's direction ``insertion`` (1:
#: ``direction``) and carries ``format``; 1 is every document without it
FORMAT = 3
#: how many of a plan's weakest steps the document and the table name
WEAKEST = 3


class PlanStatus(Enum):
    FOUND = "found"
    INFEASIBLE = "infeasible"
    BUDGET_SPENT = "budget spent"


def _finite(x: float | None) -> float | None:
    """``x``, or None where it is infinite (JSON has no infinity)."""
    return None if x is None or math.isinf(x) else x


def _pair(v) -> tuple[float, float]:
    return float(v[0]), float(v[1])


@dataclass(frozen=True)
class RobotMove:
    """Where a step's moving subassembly goes, in the assembly's units (``rap.plan.report.poses``):
    poses are translations from its assembled placement (``goal`` is (0, 0)); ``start`` the
    simulator's start, ``clearance`` clear of the fixed subassembly; ``approach`` the start pulled
    back by ``approach_distance`` along -insertion; ``travel`` the scored path's length;
    ``centroid_goal`` the moving subassembly's area centroid assembled (at a pose: plus it)."""

    start: tuple[float, float]
    approach: tuple[float, float]
    goal: tuple[float, float]
    travel: float
    clearance: float
    approach_distance: float
    centroid_goal: tuple[float, float]

    def centroid_at(self, pose: tuple[float, float]) -> tuple[float, float]:
        return self.centroid_goal[0] + pose[0], self.centroid_goal[1] + pose[1]

    def to_json(self) -> dict:
        return {"start": list(self.start), "approach": list(self.approach),
                "goal": list(self.goal), "travel": self.travel, "clearance": self.clearance,
                "approach_distance": self.approach_distance,
                "centroid": {k: list(self.centroid_at(getattr(self, k)))
                             for k in ("start", "approach", "goal")}}

    @classmethod
    def from_json(cls, doc: dict) -> "RobotMove":
        return cls(_pair(doc["start"]), _pair(doc["approach"]), _pair(doc["goal"]),
                   float(doc["travel"]), float(doc["clearance"]),
                   float(doc["approach_distance"]), _pair(doc["centroid"]["goal"]))


@dataclass(frozen=True)
class PlanStep:
    moving: tuple[str, ...]
    fixed: tuple[str, ...]
    direction: tuple[float, float]
    source: str
    score: float | None = None
    confidence: float | None = None
    operation: Operation | None = field(default=None, compare=False, repr=False)
    score_interval: tuple[float, float] | None = None
    reason: str | None = None
    robot: RobotMove | None = None
    predicted: float | None = None
    execution: StepExecution | None = None

    @property
    def insertion(self) -> tuple[float, float]:
        """The insertion direction (``direction``'s name in plan files): removal = -insertion."""
        return self.direction

    @classmethod
    def of(cls, op: Operation, source: str, confidence: float | None = None,
           score: float | None = None, predicted: float | None = None) -> "PlanStep":
        return cls(tuple(sorted(op.moving)), tuple(sorted(op.fixed)),
                   (float(op.direction[0]), float(op.direction[1])), source,
                   None if score is None else float(score),
                   None if confidence is None else float(confidence), op,
                   predicted=None if predicted is None else float(predicted))

    def to_operation(self) -> Operation:
        if self.operation is not None:
            return self.operation
        return Operation(frozenset(self.moving), frozenset(self.fixed), self.direction)

    def to_json(self) -> dict:
        return {"moving": list(self.moving), "fixed": list(self.fixed),
                "insertion": [self.direction[0] + 0.0, self.direction[1] + 0.0],  # no -0.0
                "score": self.score,
                "score_interval": None if self.score_interval is None
                else list(self.score_interval),
                "source": self.source, "confidence": self.confidence,
                "predicted": self.predicted, "reason": self.reason,
                "robot": None if self.robot is None else self.robot.to_json(),
                "execution": None if self.execution is None else self.execution.to_json()}

    @classmethod
    def from_json(cls, s: dict, fmt: int = FORMAT) -> "PlanStep":
        """A step of a plan document of format ``fmt`` (``"direction"`` for ``"insertion"`` in
        format 1; ``"cnn"`` for ``"model"`` before format 3)."""
        lo_hi, robot, ex = s.get("score_interval"), s.get("robot"), s.get("execution")
        source = str(s["source"])
        predicted = s.get("predicted")
        return cls(tuple(map(str, s["moving"])), tuple(map(str, s["fixed"])),
                   _pair(s["insertion"] if "insertion" in s else s["direction"]),
                   "model" if fmt < 3 and source == "cnn" else source,
                   None if s["score"] is None else float(s["score"]),
                   None if s["confidence"] is None else float(s["confidence"]),
                   score_interval=None if lo_hi is None else _pair(lo_hi),
                   reason=None if s.get("reason") is None else str(s["reason"]),
                   robot=None if robot is None else RobotMove.from_json(robot),
                   predicted=None if predicted is None else float(predicted),
                   execution=None if ex is None else StepExecution.from_json(ex))


def is_assembly_order(steps: Sequence[PlanStep], parts: Sequence[str]) -> str | None:
    """None when ``steps`` assemble ``parts`` in a valid order (each step's moving and fixed sets
    are single parts or were built by earlier steps; n-1 steps; the last builds everything), else
    the first problem found, as text."""
    built = {frozenset([p]) for p in parts}
    parts_set = frozenset(parts)
    if len(steps) != max(0, len(parts_set) - 1):
        return f"{len(steps)} steps for {len(parts_set)} parts (expected {len(parts_set) - 1})"
    for i, s in enumerate(steps, 1):
        m, f = frozenset(s.moving), frozenset(s.fixed)
        if not m or not f or m & f:
            return f"step {i}: moving and fixed must be non-empty and disjoint"
        for name, side in (("moving", m), ("fixed", f)):
            if side not in built:
                return f"step {i}: {name} {{{','.join(sorted(side))}}} was not assembled before"
        built.discard(m)
        built.discard(f)
        built.add(m | f)
    if len(parts_set) > 1 and parts_set not in built:
        return "the steps do not assemble every part"
    return None


@dataclass(frozen=True)
class PlanResult:
    """The outcome of one planner run (see module doc). ``seconds``: time to find the sequence;
    ``eval_seconds``: time to evaluate it with the simulator afterwards (0 when every step's score
    was already known); ``stats``: counters (CNN batches, simulations, cache hits, fallbacks, ...);
    ``units``: the assembly's units; ``trials``: simulator trials behind each score;
    ``robustness_interval``: R's interval at ``confidence_level`` (``rap.plan.report.intervals``);
    ``bound``: an upper bound on the optimum's robustness, with its confidence and the plan's gap
    to it (methods that bound; ``rap.plan.search.scores.report``), else None (no key in JSON)."""

    status: PlanStatus
    method: str
    assembly: str
    steps: tuple[PlanStep, ...] = ()
    robustness: float | None = None
    seconds: float = 0.0
    eval_seconds: float = 0.0
    interlocked: tuple[str, ...] | None = None
    stats: dict = field(default_factory=dict)
    message: str = ""
    units: str = "unit"
    trials: int | None = None
    robustness_interval: tuple[float, float] | None = None
    confidence_level: float | None = None
    bound: dict | None = None  # the optimum's upper bound (rap.plan.search.scores.report)
    sequence: SequenceReport | None = None  # measured by rollouts (``sequence_success``)

    @property
    def found(self) -> bool:
        return self.status is PlanStatus.FOUND

    def with_(self, **changes) -> "PlanResult":
        return replace(self, **changes)

    @classmethod
    def from_json(cls, doc: dict, *, eval_seconds: float = 0.0,
                  stats: dict | None = None) -> "PlanResult":
        """The result described by a ``to_json()`` document (``eval_seconds`` and ``stats`` are
        not in it). Reads every format up to ``FORMAT`` (a document without ``format`` is
        format 1, whose steps say ``direction`` for ``insertion``). Raises ``ValueError`` for a
        document of another shape or a newer format."""
        fmt = doc.get("format", 1) if isinstance(doc, dict) else None
        if not isinstance(fmt, int) or isinstance(fmt, bool) or not 1 <= fmt <= FORMAT:
            raise ValueError(f"plan format {fmt!r}: this rap-farm reads formats 1 to {FORMAT}")
        try:
            feasible = doc["feasible"]
            cell = {k: doc[k] for k in ("constraints", "score_note", "guard")
                    if doc.get(k) is not None}
            common = dict(method=str(doc["method"]), assembly=str(doc["assembly"]),
                          eval_seconds=float(eval_seconds), stats={**cell, **(stats or {})})
            if feasible is True:
                steps = tuple(PlanStep.from_json(s, fmt) for s in doc["steps"])
                seq = doc.get("sequence_success")
                r, r_lo_hi = doc["robustness"], doc.get("robustness_interval")
                trials, level = doc.get("trials"), doc.get("confidence_level")
                return cls(PlanStatus.FOUND, steps=steps, robustness=None if r is None else float(r),
                           seconds=float(doc["seconds"]), units=str(doc.get("units", "unit")),
                           trials=None if trials is None else int(trials),
                           robustness_interval=None if r_lo_hi is None else _pair(r_lo_hi),
                           confidence_level=None if level is None else float(level),
                           bound=None if doc.get("bound") is None else dict(doc["bound"]),
                           sequence=None if seq is None else SequenceReport.from_json(seq),
                           **common)
            if feasible is False:
                parts = tuple(map(str, doc["interlocked"]))
                message = doc.get("message") or interlocked_message(common["assembly"], parts)
                return cls(PlanStatus.INFEASIBLE, interlocked=parts, message=str(message),
                           **common)
            return cls(PlanStatus(doc["status"]), seconds=float(doc["seconds"]),
                       message=str(doc["message"]), **common)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"not a plan document ({type(exc).__name__}: {exc})") from None

    def _cell_json(self) -> dict:
        """The robot cell's constraints and what the scores cover, when the plan had any
        (``rap.plan.cell.rules.constraint_stats``: ``constraints``, ``score_note`` in ``stats``),
        and ``guard`` when the default scorer found the assembly unfamiliar and acted
        (``rap.plan.scoring.familiarity.guard_stats``)."""
        return {k: self.stats[k] for k in ("constraints", "score_note", "guard")
                if k in self.stats}

    @property
    def expected_failures(self) -> float | None:
        """The expected number of failed steps, ``sum(1 - r)`` over the steps (None when a score
        is unknown): beside R, what a long plan's reader can weigh (R = 0.000 at 100 steps says
        nothing of whether the failures are spread or concentrated)."""
        if not self.steps or any(s.score is None for s in self.steps):
            return None if self.steps else 0.0
        return float(sum(1.0 - s.score for s in self.steps))  # type: ignore[operator]

    @property
    def expected_attempts(self) -> float | None:
        """The expected number of attempts when a failed step is retried until it succeeds,
        ``sum(1/r)`` over the steps (at least the number of steps; ``rap.stats``):
        infinite when a step scores 0 (it never succeeds; the JSON writes null), None when a
        score is unknown, 0 for a plan with no step."""
        if not self.steps or any(s.score is None for s in self.steps):
            return None if self.steps else 0.0
        return float(sum(expected_attempts(s.score) for s in self.steps))  # type: ignore[arg-type]

    def weakest_steps(self, k: int = WEAKEST) -> list[int]:
        """The numbers (1-based, assembly order) of the ``k`` steps of lowest score, weakest
        first (ties: the earlier step); only steps whose score is below 1."""
        scored = [(s.score, i) for i, s in enumerate(self.steps, 1)
                  if s.score is not None and s.score < 1.0]
        return [i for _, i in sorted(scored)[:k]]

    def to_json(self) -> dict:
        """The ``--out`` document: exactly the keys documented for ``rap-farm plan``, with its
        ``format`` (``FORMAT``) first."""
        return {"format": FORMAT, **self._document()}

    def _document(self) -> dict:
        if self.status is PlanStatus.FOUND:
            return {"assembly": self.assembly, "method": self.method, "feasible": True,
                    "units": self.units, "robustness": self.robustness,
                    "robustness_interval": None if self.robustness_interval is None
                    else list(self.robustness_interval),
                    "confidence_level": self.confidence_level, "trials": self.trials,
                    "expected_failures": self.expected_failures,
                    "expected_attempts": _finite(self.expected_attempts),
                    "weakest_steps": self.weakest_steps(),
                    "steps": [s.to_json() for s in self.steps], "seconds": self.seconds,
                    **({} if self.bound is None else {"bound": dict(self.bound)}),
                    "sequence_success": None if self.sequence is None
                    else self.sequence.to_json(),
                    **self._cell_json()}
        if self.status is PlanStatus.INFEASIBLE:
            return {"assembly": self.assembly, "method": self.method, "feasible": False,
                    "interlocked": list(self.interlocked or ()), "message": self.message,
                    **self._cell_json()}
        return {"assembly": self.assembly, "method": self.method, "feasible": None,
                "status": self.status.value, "message": self.message, "seconds": self.seconds}
