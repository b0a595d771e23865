"""The cell's error model: how far off its place a part is when the arm puts it in.

Two sources, sampled afresh for every step of every rollout (``rap.execution.rollout``) and by the
simulated arm (``rap.robot.arm_sim``):

* **the grasp**: the part sits off the cup's expected place by ``U(-across, across)`` across the
  insertion, ``U(-along, along)`` along it, and is turned by ``U(-angle, angle)`` (where the part
  lay in the tray, how the cup's lip settled on it);
* **the arm's repeatability** (ISO 9283 RP, the maker's figure): the tool point lands uniformly in a
  disc of that radius around the commanded one.

Defaults (``DEFAULT_ERRORS``), documented in docs/ROBOT.md:

* repeatability 0.1 mm: Franka Emika Panda, the shipped cell's arm ("Repeatability +/-0.1 mm", the
  Panda's datasheet, ISO 9283); a cell names its arm and takes that arm's figure unless it sets
  its own;
* grasp 0.5 mm across and along, 0.5 degrees: **our estimate, not a maker's figure**. Makers of
  suction cups (the shipped 12 mm flat cup) publish holding forces, not where the part ends up
  under the cup; the error is that of the pick (a part in a tray slot, picked blind). Measure your
  cell's and set it in ``[errors]``.

``force_noise`` (True by default) keeps the simulator's actuation noise in the rollouts, the
compliant controller under force noise that the step scores measure; False models a stiff,
position-controlled arm, whose only errors are the position errors above (rollouts then run with
``eta = 0``: what the simulated arm does, ``benchmarks/arm_vs_rollouts.py``).

``zero()`` turns every error off (the control: rollouts then measure carried noise alone).
Lengths in mm, the angle in degrees; ``offsets`` converts to assembly units with ``mm_per_unit``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["ErrorModel", "DEFAULT_ERRORS", "ERROR_KEYS"]

#: the keys of a cell file's ``[errors]`` table (the fields of ``ErrorModel``)
ERROR_KEYS = ("grasp_across_mm", "grasp_along_mm", "grasp_angle_deg", "repeatability_mm")


@dataclass(frozen=True)
class ErrorModel:
    """Bounds of a part's placement error (module doc); all >= 0."""

    grasp_across_mm: float = 0.5
    grasp_along_mm: float = 0.5
    grasp_angle_deg: float = 0.5
    repeatability_mm: float = 0.1
    force_noise: bool = True

    def __post_init__(self):
        if not isinstance(self.force_noise, bool):
            raise ValueError(f"force_noise must be true or false, not {self.force_noise!r}")
        for k in ERROR_KEYS:
            v = getattr(self, k)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) \
                    or v < 0:
                raise ValueError(f"{k} must be a number >= 0, not {v!r}")

    @staticmethod
    def zero() -> "ErrorModel":
        return ErrorModel(0.0, 0.0, 0.0, 0.0)

    @property
    def is_zero(self) -> bool:
        """No position error (the force noise is the simulator's, not this model's)."""
        return not any(getattr(self, k) for k in ERROR_KEYS)

    @property
    def budget_across_mm(self) -> float:
        """The largest error across an insertion this model puts a part at: grasp plus arm. A step
        whose ``tolerance_mm`` is below it can fail for this cell's errors alone."""
        return self.grasp_across_mm + self.repeatability_mm

    def to_dict(self) -> dict:
        return asdict(self)

    def offsets(self, rng: np.random.Generator, direction: tuple[float, float],
                mm_per_unit: float) -> tuple[float, float, float]:
        """One draw: ``(dx, dy, angle_rad)`` of the part off its commanded place, in assembly
        units and assembly axes, for an insertion along the unit ``direction``. Always draws five
        numbers from ``rng``, in a fixed order, so what follows does not depend on the bounds."""
        u = rng.uniform(-1.0, 1.0, 3)
        disc = rng.random(2)  # the arm: uniform in the disc of radius RP
        r, phi = self.repeatability_mm * math.sqrt(disc[0]), 2.0 * math.pi * disc[1]
        across = self.grasp_across_mm * u[0] + r * math.sin(phi)
        along = self.grasp_along_mm * u[1] + r * math.cos(phi)
        dx, dy = direction
        per = 1.0 / mm_per_unit
        return ((along * dx - across * dy) * per, (along * dy + across * dx) * per,
                math.radians(self.grasp_angle_deg) * u[2])


DEFAULT_ERRORS = ErrorModel()
