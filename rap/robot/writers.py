"""A ``Program`` as text: waypoints (CSV or JSON) or a URScript program; written atomically.

* **waypoints, CSV** (``WAYPOINT_COLUMNS``): one row a waypoint: ``step, name, motion, part, x_m,
  y_m, z_m, rx, ry, rz`` (the tool's rotation vector, radians), ``speed`` (rad/s for movej, m/s
  for movel), ``acceleration``, ``action`` (``grip_on``, ``grip_off`` or empty: done on arrival).
* **waypoints, JSON**: ``{"assembly", "fixture", "plane", "units": "m", "frame": {origin, ex, ey,
  scale_m}, "cell": the cell's sections, "waypoints": [rows as objects]}``.
* **URScript**: one ``def rap_farm_program(): ... end`` with a comment per step, ``movej`` /
  ``movel`` to ``p[x, y, z, rx, ry, rz]`` poses with ``a=`` and ``v=``, and the vacuum switched by
  ``set_digital_out(OUTPUT, True/False)`` followed by a ``sleep`` (the cup's settling time).

Numbers are written with 6 decimals (micrometres; ``+ 0.0`` keeps ``-0`` out). ``write_program``
writes atomically with the umask's mode (``rap.files.write_text_atomic``). Cost: O(waypoints).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from rap.files import write_text_atomic
from rap.robot.program import Program

__all__ = ["WAYPOINT_COLUMNS", "FORMATS", "waypoint_rows", "waypoints_csv", "waypoints_json",
           "urscript", "render", "write_program", "GRIP_SETTLE_S"]

WAYPOINT_COLUMNS = ("step", "name", "motion", "part", "x_m", "y_m", "z_m", "rx", "ry", "rz",
                    "speed", "acceleration", "action")
FORMATS = ("waypoints", "urscript")
GRIP_SETTLE_S = 0.2  # seconds the program waits after switching the vacuum


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


def _pose(w) -> str:
    return "p[" + ", ".join(f"{_f(v):.6f}" for v in (*w.position, *w.rotvec)) + "]"


def urscript(program: Program) -> str:
    """The URScript program (module doc)."""
    out = program.cell.gripper.output
    lines = [f"# rap-farm robot program: assembly {program.assembly}, {len(program.steps)} steps, "
             f"fixture {program.fixture}, cell {program.cell.source}",
             "# poses p[x, y, z, rx, ry, rz]: metres and a rotation vector (radians) in the "
             "robot's base frame; the tool points down",
             "def rap_farm_program():",
             f"  set_digital_out({out}, False)"]
    for s in program.steps:
        i = s.insertion
        score = "?" if s.score is None else f"{s.score:.2f}"
        lines.append(f"  # step {s.index}: {s.part} into {{{','.join(s.fixed)}}}, insertion "
                     f"({_f(i[0]):.3f}, {_f(i[1]):.3f}, {_f(i[2]):.3f}), score {score}")
        for w in s.waypoints:
            lines.append(f"  {w.motion}({_pose(w)}, a={w.acceleration:g}, v={w.speed:g})"
                         f"  # {w.name}")
            if w.action:
                on = "True" if w.action == "grip_on" else "False"
                lines.append(f"  set_digital_out({out}, {on})")
                lines.append(f"  sleep({GRIP_SETTLE_S:g})")
    lines.append("end")
    return "\n".join(lines) + "\n"


def render(program: Program, fmt: str, suffix: str = ".json") -> str:
    """The text of ``program`` in ``fmt`` (``waypoints``: CSV when ``suffix`` is ``.csv``, else
    JSON; ``urscript``)."""
    if fmt == "urscript":
        return urscript(program)
    return waypoints_csv(program) if suffix.lower() == ".csv" else waypoints_json(program)


def write_program(program: Program, path: str | Path, fmt: str) -> Path:
    """Write ``render(program, fmt)`` to ``path`` atomically. Raises ``OSError``."""
    path = Path(path)
    text = render(program, fmt, path.suffix)
    return write_text_atomic(path, text, newline="" if path.suffix.lower() == ".csv" else None)
