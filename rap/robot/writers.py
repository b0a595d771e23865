"""A ``Program``'s Cartesian waypoints as text, CSV or JSON: any arm's format (no kinematics).

* **waypoints, CSV** (``WAYPOINT_COLUMNS``): one row a waypoint: ``step, name, motion, part, x_m,
  y_m, z_m, rx, ry, rz`` (the tool's rotation vector, radians), ``speed`` (rad/s for movej, m/s
  for movel), ``acceleration``, ``action`` (``grip_on``, ``grip_off`` or empty: done on arrival).
* **waypoints, JSON**: ``{"assembly", "fixture", "plane", "units": "m", "frame": {origin, ex, ey,
  scale_m}, "cell": the cell's sections, "waypoints": [rows as objects]}``.

The arm's own formats (URScript with joint targets, the Panda's joint trajectory) are written by
``rap.robot.arms``; ``rap.robot.arms.export.render`` is the door to all of them. Numbers are
written with 6 decimals (micrometres; ``+ 0.0`` keeps ``-0`` out). Cost: O(waypoints).
"""

from __future__ import annotations

import csv
import io
import json
from rap.robot.program import Program

__all__ = ["WAYPOINT_COLUMNS", "waypoint_rows", "waypoints_csv", "waypoints_json"]

WAYPOINT_COLUMNS = ("step", "name", "motion", "part", "x_m", "y_m", "z_m", "rx", "ry", "rz",
                    "speed", "acceleration", "action")


def _f(x: float) -> float:
    return round(float(x), 6) + 0.0


def waypoint_rows(program: Program) -> list[dict]:
    """One dict per waypoint, keyed by ``WAYPOINT_COLUMNS``."""
    return [{"step": w.step, "name": w.name, "motion": w.motion, "part": w.part,
             "x_m": _f(w.position[0]), "y_m": _f(w.position[1]), "z_m": _f(w.position[2]),
             "rx": _f(w.rotvec[0]), "ry": _f(w.rotvec[1]), "rz": _f(w.rotvec[2]),
             "speed": w.speed, "acceleration": w.acceleration, "action": w.action}
            for w in program.waypoints]


def waypoints_csv(program: Program) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=WAYPOINT_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(waypoint_rows(program))
    return buf.getvalue()


def waypoints_json(program: Program) -> str:
    fr = program.frame
    doc = {"assembly": program.assembly, "fixture": program.fixture, "plane": fr.plane,
           "units": "m",
           "frame": {"origin": [_f(v) for v in fr.origin], "ex": [_f(v) for v in fr.ex],
                     "ey": [_f(v) for v in fr.ey], "anchor": list(fr.anchor),
                     "scale_m": fr.scale_m},
           "cell": program.cell.to_dict(), "waypoints": waypoint_rows(program)}
    return json.dumps(doc, indent=1) + "\n"
