"""What a plan says about its execution (plan format 3): the whole sequence's measured success
under the cell's errors, and per step its success once reached, its clearance and its tolerance.

* ``SequenceReport``: ``sequence_success`` (rollouts of the whole plan, each step starting where the
  earlier ones left the parts, ``rap.execution``), its 95% Clopper-Pearson interval, the rollouts,
  the error model they sampled (``errors``, mm and degrees), the root seed, and how the plan was
  chosen (``chosen_by``: ``"product"`` when it is the search's best product of scores,
  ``"sequence success"`` when the chooser measured other candidates and this one did best;
  ``candidates``: what each candidate measured).
* ``StepExecution``: ``reached`` (rollouts that reached the step), ``success_when_reached`` and its
  interval, ``clearance_mm`` (free play across the insertion at the goal, exact; None: nothing
  across), ``tolerance_mm`` (the largest error across that costs the step at most a tenth of its
  success, simulated) and ``below_budget`` (the tolerance is below the cell's error budget across,
  ``ErrorModel.budget_across_mm``: this step can fail for the cell's errors alone).

Pure data with JSON in and out; no simulation here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["SequenceReport", "StepExecution"]


def _opt_float(v) -> float | None:
    return None if v is None else float(v)


def _opt_pair(v) -> tuple[float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]))


@dataclass(frozen=True)
class StepExecution:
    reached: int | None = None
    success_when_reached: float | None = None
    interval: tuple[float, float] | None = None
    clearance_mm: float | None = None
    tolerance_mm: float | None = None
    below_budget: bool | None = None

    def to_json(self) -> dict:
        return {"reached": self.reached, "success_when_reached": self.success_when_reached,
                "success_when_reached_interval": None if self.interval is None
                else list(self.interval),
                "clearance_mm": self.clearance_mm, "tolerance_mm": self.tolerance_mm,
                "below_budget": self.below_budget}

    @classmethod
    def from_json(cls, d: dict) -> "StepExecution":
        below = d.get("below_budget")
        return cls(None if d.get("reached") is None else int(d["reached"]),
                   _opt_float(d.get("success_when_reached")),
                   _opt_pair(d.get("success_when_reached_interval")),
                   _opt_float(d.get("clearance_mm")), _opt_float(d.get("tolerance_mm")),
                   None if below is None else bool(below))


@dataclass(frozen=True)
class SequenceReport:
    success: float
    interval: tuple[float, float]
    successes: int
    rollouts: int
    errors: dict
    seed: int
    chosen_by: str = "product"
    candidates: tuple[dict, ...] = field(default=())
    seconds: float = 0.0
    level: float = 0.95

    def text(self) -> str:
        lo, hi = self.interval
        return f"sequence success {self.success:.3f} [{lo:.3f}, {hi:.3f}] ({self.rollouts} rollouts)"

    def to_json(self) -> dict:
        return {"rate": self.success, "interval": list(self.interval), "level": self.level,
                "successes": self.successes, "rollouts": self.rollouts, "errors": dict(self.errors),
                "seed": self.seed, "chosen_by": self.chosen_by,
                "candidates": [dict(c) for c in self.candidates],
                "seconds": round(self.seconds, 3)}

    @classmethod
    def from_json(cls, d: dict) -> "SequenceReport":
        return cls(float(d["rate"]), _opt_pair(d["interval"]), int(d["successes"]),
                   int(d["rollouts"]), dict(d.get("errors") or {}), int(d.get("seed", 0)),
                   str(d.get("chosen_by", "product")),
                   tuple(dict(c) for c in d.get("candidates") or ()),
                   float(d.get("seconds", 0.0)), float(d.get("level", 0.95)))
