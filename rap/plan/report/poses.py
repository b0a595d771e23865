"""Robot-ready steps: where each step's moving parts start, approach and end, in the assembly's units.

A step inserts its ``moving`` subassembly into its ``fixed`` one along the unit vector
``insertion`` (the removal direction of the NDBG is ``-insertion``). ``robot_move`` gives, in
the assembly's units (``Assembly.units``; ``"unit"`` when the drawing named none):

* a **pose** is the translation ``(x, y)`` of the moving subassembly from its assembled
  placement (no rotation: every operation is a translation). The **goal** pose is ``(0, 0)``.
* the **start** pose is the simulator's own start (``rap.sim.placement``, with the simulator's
  ``start_gap``), so what a robot does is what was scored: ``-travel * insertion``, where the
  moving subassembly is clear of the fixed subassembly's bounding box (in the frame aligned with
  the insertion) by at least the **clearance** ``start_gap * extent`` along the insertion;
* the **approach** waypoint is the start pulled back along ``-insertion`` by the **approach
  distance** (default: the clearance): the robot moves there freely, then straight along the
  insertion to the start and on to the goal; only start -> goal was simulated;
* **travel** is the length of the scored straight insertion, ``|start - goal|``;
* the **centroid** (the moving subassembly's area centroid, the simulator's reference point) at
  the start, the approach and the goal, in assembly coordinates: a point's place at a pose is its
  assembled place plus the pose.

``annotate_plan(result, problem)`` fills a found ``PlanResult`` with what a controller and a user
read: the units, the trials, each step's robot move, its score's confidence interval
(``rap.plan.report.intervals``) and its reason (``rap.plan.report.reasons``), and R's interval.
A free step (``PlanningProblem.is_free``: its moving parts touch nothing along the insertion or at
the goal) is robust by geometry: source ``free``, score 1 with the interval [1, 1], reason "free:
no contact", and it leaves R's interval alone (its factor is exactly 1).
``plan_rows(result)`` are the rows of ``rap-farm plan --csv`` (``CSV_COLUMNS``).

Floats (motion, not predicates); the centroid is computed exactly and converted. The CSV's
numbers are rounded to 12 decimals (``tidy``): the motion's floats carry noise such as
``cos(pi/2) = 6e-17`` that a controller should read as 0. Cost of
``annotate_plan``: one NDBG of the assembly (for the reasons) and O(vertices) per step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

from rap.assembly import Assembly, area_moments
from rap.operation import Operation
from rap.plan.report.result import PlanResult, PlanStatus, RobotMove
from rap.sim.placement import placement

__all__ = ["RobotMove", "robot_move", "centroid", "annotate_plan", "plan_rows", "tidy",
           "CSV_COLUMNS"]

#: the columns of ``rap-farm plan --csv``, in order (README, "Plan files")
CSV_COLUMNS = ("step", "moving", "fixed", "insertion_x", "insertion_y", "start_x", "start_y",
               "approach_x", "approach_y", "goal_x", "goal_y", "travel", "centroid_x",
               "centroid_y", "units", "score", "score_low", "score_high", "source", "reason",
               "weakest_rank", "success_when_reached", "clearance_mm", "tolerance_mm",
               "below_budget")


def centroid(assembly: Assembly, ids: Sequence[str]) -> tuple[float, float]:
    """The area centroid of the parts ``ids`` (holes subtracted), exact then converted."""
    a2, cx, cy = area_moments(ring for pid in ids for ring in assembly.part(pid).rings())
    return float(cx / (3 * a2)), float(cy / (3 * a2))


def robot_move(assembly: Assembly, op: Operation, start_gap: float,
               approach_distance: float | None = None) -> RobotMove:
    """The step's poses (module doc) with the simulator's ``start_gap`` (``SimParams.start_gap``);
    ``approach_distance`` in assembly units (None: the clearance)."""
    pl = placement(assembly, op, start_gap)
    dx, dy = pl.direction
    clearance = start_gap * pl.extent
    back = clearance if approach_distance is None else float(approach_distance)
    start = pl.start_offset
    approach = (start[0] - back * dx, start[1] - back * dy)
    gx, gy = centroid(assembly, sorted(op.moving))
    return RobotMove(start=(start[0] + 0.0, start[1] + 0.0),
                     approach=(approach[0] + 0.0, approach[1] + 0.0), goal=(0.0, 0.0),
                     travel=pl.travel, clearance=clearance, approach_distance=back,
                     centroid_goal=(gx, gy))


def annotate_plan(result: PlanResult, problem, approach_distance: float | None = None
                  ) -> PlanResult:
    """``result`` with its units and trials, and, when found, each step's robot move, score
    interval and reason and R's interval (module doc). ``problem``: the ``PlanningProblem``
    (its assembly and its simulator parameters: ``trials``, ``start_gap``). A reason that cannot
    be computed (an operation the descriptors refuse) is left None."""
    from rap.plan.report.intervals import LEVEL, robustness_interval, step_interval

    assembly = problem.assembly
    trials = getattr(problem.params, "trials", None)
    out = replace(result, units=assembly.units, trials=trials)
    if result.status is not PlanStatus.FOUND:
        return out
    from rap.model.data.descriptors import DescriptorContext
    from rap.plan.report.reasons import FREE_REASON, step_reason

    context = DescriptorContext(assembly) if result.steps else None
    start_gap = getattr(problem.params, "start_gap", 0.1)
    steps, drawn = [], []
    for s in result.steps:
        op = s.to_operation()
        robot = robot_move(assembly, op, start_gap, approach_distance)
        if problem.is_free(op):  # robust by geometry: 1 exactly, nothing sampled
            steps.append(replace(s, source="free", confidence=None, score_interval=(1.0, 1.0),
                                 reason=FREE_REASON, robot=robot))
            continue
        try:
            reason = step_reason(context, op, assembly.units)
        except ValueError:
            reason = None
        steps.append(replace(s, score_interval=step_interval(s.score, trials), reason=reason,
                             robot=robot))
        drawn.append(s.score)
    interval = robustness_interval(drawn, trials)  # free steps' factors are exactly 1
    return replace(out, steps=tuple(steps), robustness_interval=interval,
                   confidence_level=None if interval is None else LEVEL)


def tidy(x: float) -> float:
    """``x`` rounded to 12 decimals, without a negative zero (a controller's reading)."""
    return round(float(x), 12) + 0.0


def plan_rows(result: PlanResult) -> list[dict]:
    """One dict per step of a found plan, keyed by ``CSV_COLUMNS`` (part ids joined by commas,
    as the table shows them: ids never hold one; unknown values as empty strings)."""
    rows = []
    rank = {step: n for n, step in enumerate(result.weakest_steps(), 1)}
    for k, s in enumerate(result.steps, 1):
        r, lo_hi = s.robot, s.score_interval
        row = {"step": k, "moving": ",".join(s.moving), "fixed": ",".join(s.fixed),
               "insertion_x": tidy(s.insertion[0]), "insertion_y": tidy(s.insertion[1]),
               "units": result.units, "score": "" if s.score is None else s.score,
               "score_low": "" if lo_hi is None else lo_hi[0],
               "score_high": "" if lo_hi is None else lo_hi[1],
               "source": s.source, "reason": s.reason or "", "weakest_rank": rank.get(k, "")}
        for name in ("start", "approach", "goal"):
            xy = None if r is None else getattr(r, name)
            row[f"{name}_x"] = "" if xy is None else tidy(xy[0])
            row[f"{name}_y"] = "" if xy is None else tidy(xy[1])
        row["travel"] = "" if r is None else tidy(r.travel)
        row["centroid_x"] = "" if r is None else tidy(r.centroid_goal[0])
        row["centroid_y"] = "" if r is None else tidy(r.centroid_goal[1])
        ex = s.execution  # plan format 3: what the rollouts measured (empty without them)
        for name in ("success_when_reached", "clearance_mm", "tolerance_mm", "below_budget"):
            v = None if ex is None else getattr(ex, name)
            row[name] = "" if v is None else v
        rows.append({c: row[c] for c in CSV_COLUMNS})
    return rows
