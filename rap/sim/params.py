"""Simulator parameters: every constant of the robustness simulator in one frozen dataclass.

Lengths are in *world units*: each operation is simulated in a frame scaled so that the
subassembly (moving and fixed parts together) spans ``world_size`` units along its larger extent in
the frame aligned with the direction of motion (see ``rap.sim.placement``). Gains are
mass-normalised (accelerations), so the controller behaves the same for every part size and
density. Times are in seconds, angles in radians.

The parameters are stored with every label (``to_dict``) and enter the label's seed and content key
through ``fingerprint()``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, replace
from functools import cached_property

from rap.config import strict_from_dict

__all__ = ["SimParams", "DEFAULT_PARAMS"]


@dataclass(frozen=True)
class SimParams:
    # --- trials and noise -------------------------------------------------------------------
    trials: int = 100
    eta: float = 9.0  # perpendicular actuation noise: uniform in [-eta|F|, eta|F|] per control step

    # --- scene ------------------------------------------------------------------------------
    world_size: float = 100.0  # larger extent of the subassembly, world units
    start_gap: float = 0.1  # start clearance to the fixed bounding box, fraction of world_size
    density: float = 1.0e-3  # uniform density of the moving body (mass per world unit^2)
    friction: float = 0.3  # Coulomb friction coefficient of every shape
    elasticity: float = 0.0  # restitution of every shape
    poly_radius: float = 0.0  # pymunk polygon rounding radius (0: exact convex pieces)
    collision_slop: float = 0.05  # Chipmunk allowed penetration, world units
    iterations: int = 10  # Chipmunk solver iterations per step
    # a part of more convex pieces than this is simulated through at most this many, merged
    # within shape_tolerance x its own extent (doubled where the count needs it): rap.sim.outline
    shape_pieces: int = 32
    shape_tolerance: float = 0.002

    # --- time -------------------------------------------------------------------------------
    dt_s: float = 1.0 / 120.0  # physics step
    control_substeps: int = 1  # physics steps per control step (forces held; checks per control step)
    time_limit_s: float = 16.0  # a trial succeeds only if it reaches the goal within this time (8 s
    # cut off slow-but-sure insertions: docs/RESULTS.md, "Simulator")

    # --- controller (proportional feedback toward a carrot on the straight path) --------------
    carrot_speed: float = 40.0  # world units / s the carrot advances along the path
    carrot_lead: float = 15.0  # the carrot stays at most this far ahead of the body's projection
    kp: float = 30.0  # 1/s^2: acceleration per unit of position error
    kd: float = 11.0  # 1/s: acceleration per unit of velocity
    kp_angle: float = 60.0  # 1/s^2: angular acceleration per radian of orientation error
    kd_angle: float = 16.0  # 1/s: angular acceleration per rad/s
    max_accel: float = 1000.0  # cap of the commanded acceleration (before noise), world units/s^2
    max_angular_accel: float = 200.0  # cap of the commanded angular acceleration, rad/s^2

    # --- success ------------------------------------------------------------------------------
    pos_tol: float = 0.05  # success radius, fraction of the moving subassembly's extent
    angle_tol_rad: float = 0.05

    # --- hopeless trials (part of the outcome's definition: decided failures) -------------------
    far_off: float = 1.5  # distance from the path segment beyond which a trial fails, x world_size
    stuck_s: float = 0.0  # > 0: a trial fails when its best distance to the goal has not improved
    stuck_progress: float = 0.01  # ... by this fraction of world_size for stuck_s seconds (0: off)
    retire: bool = True  # remove decided trials from the space (less work; see ``fingerprint``)

    # --- layout of the trials in one space ------------------------------------------------------
    trial_spacing: float = 8.0  # distance between neighbouring trials, x world_size

    def __post_init__(self):
        if self.trials < 1:
            raise ValueError("trials must be at least 1")
        if self.eta < 0:
            raise ValueError("eta must be non-negative")
        if not (self.dt_s > 0 and self.time_limit_s > 0 and self.world_size > 0):
            raise ValueError("dt_s, time_limit_s and world_size must be positive")
        if self.shape_pieces < 1 or self.shape_tolerance < 0:
            raise ValueError("shape_pieces must be at least 1 and shape_tolerance non-negative")

    @property
    def steps(self) -> int:
        """Number of physics/control steps in the time limit."""
        return int(round(self.time_limit_s / self.dt_s))

    def to_dict(self) -> dict:
        """JSON-able dict of every field (floats, ints, bools)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "SimParams":
        """Inverse of ``to_dict``; unknown keys raise ``ValueError``, missing keys take defaults."""
        return strict_from_dict(cls, data, "simulator parameters")

    def fingerprint(self) -> str:
        """Short hex (16 chars) SHA-256 of the sorted JSON of ``to_dict()``.

        ``retire`` counts only when off (the default's fingerprint, and so every label key, is as
        it always was): what else is in the space changes the order in which Chipmunk's solver
        visits a body's contacts, so a trial that touches several pieces at once can end otherwise
        without retirement (2 of 8 grid operations moved by one success). ``shape_pieces`` and
        ``shape_tolerance`` count only when changed: at their defaults every part of at most 32
        convex pieces is simulated exactly as before they existed, and every part of the
        corpus, the reference and the unseen assemblies has at most 11 (a part of more, a
        curved part from a drawing, was never labelled). Computed once per instance (planners
        ask for it per operation).
        """
        return self._fingerprint

    @cached_property
    def _fingerprint(self) -> str:
        d = self.to_dict()
        if d["retire"]:
            d.pop("retire")
        for name in ("shape_pieces", "shape_tolerance"):  # counted only when changed (docstring)
            if d[name] == SimParams.__dataclass_fields__[name].default:
                d.pop(name)
        text = json.dumps(d, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def with_(self, **changes) -> "SimParams":
        return replace(self, **changes)


DEFAULT_PARAMS = SimParams()
