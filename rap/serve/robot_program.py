"""The service's robot program (``POST /export``): a plan and its assembly in, an arm's program out.

``parse_export_request(body)`` reads a ``POST /export`` body, ``{"assembly": <assembly JSON, as
POST /plan takes it>, "plan": <the plan document POST /plan answered>, "arm": "panda" | "ur5e" |
"ur10e" (optional; default the cell's ``[robot] arm``), "format": one of
``rap.robot.arms.registry.FORMATS`` that the arm takes (default the arm's first: URScript for a
UR, the YAML joint trajectory for the Panda), "cell": <a cell file's TOML text> (optional;
default the shipped cell, rap/robot/default_cell.toml)}``, into an ``ExportRequest``, or
raises ``BadRequest`` (400, one line): a body that is not JSON or not an object of those keys, an
invalid assembly (the CLI's ``AssemblyError`` line; 413 past ``max_parts`` parts), a plan document
that is not a found plan, or not a plan of that assembly (a part it lacks; steps that do not build
it, ``is_assembly_order``), a number in the plan that is not a finite float, an unknown arm, an
unknown format or one the arm does not take (the CLI's line), a cell that is not TOML or has a
bad key (``rap.robot.cell``'s line naming the key).

``program_file(request)`` builds the program as ``rap-farm export`` does (``rap.robot.program.
build_program``, then ``rap.robot.arms.export.export_text``: the arm's kinematic check and the
format's writer) and returns a ``ProgramFile``: the text, its attachment file name (the assembly's
name and the format's ending: ``ASSEMBLY.script``, ``ASSEMBLY-trajectory.yaml``,
``ASSEMBLY-waypoints.csv``, ...), its media type, and the check's figures. Refusals are ``BadRequest`` with the CLI's one line: 422 for a plan one
arm cannot build (``TwoHandedPlan``: made without a fixture, ``plan --base``, or with a step that
needs a second hand) and for a step out of the arm's reach (``Unreachable``: the step, the
waypoint, the point and the limit); 400 for a part the suction cup finds no place on.

No ray and no fastapi here (``rap.serve.http_app`` serves it, off its event loop); pybullet is
imported on the first ``program_file``. Cost: one JSON parse and the assembly's exact validation,
then O(waypoints) for the program and about 50 IK solves a step for the check (0.3 ms each; the
22-step wall in under 1 s, docs/ROBOT.md).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from decimal import Decimal

from rap.assembly import LIMITS, Assembly
from rap.errors import InputError
from rap.plan.report.result import PlanResult, is_assembly_order
from rap.robot.arms.registry import ARMS, FORMATS, arm_spec, check_format
from rap.robot.cell import Cell, cell_from_toml, with_
from rap.robot.inputs import check_assembly, plan_of
from rap.serve.api import BadRequest, ServeConfig, request_assembly, request_object

__all__ = ["EXPORT_KEYS", "EXPORT_FORMATS", "DEFAULT_FORMAT", "PROGRAM_DETAILS_HEADER",
           "ExportRequest", "ProgramFile", "parse_export_request", "program_file",
           "EXPORT_OPENAPI"]

EXPORT_KEYS = ("assembly", "plan", "arm", "format", "cell")
#: format -> (the file name's ending after the assembly's name, media type): the registry's
EXPORT_FORMATS = {f.name: (f.ending, f.media_type) for f in FORMATS.values()}
DEFAULT_FORMAT = None  # the arm's first format
PROGRAM_DETAILS_HEADER = "X-Program-Details"  # {"steps", "waypoints", "solves", ...} of the check


@dataclass(frozen=True)
class ExportRequest:
    """A read ``POST /export`` body: the assembly, the found plan, the format and the cell."""

    assembly: Assembly
    plan: PlanResult
    format: str
    cell: Cell


@dataclass(frozen=True)
class ProgramFile:
    """What ``POST /export`` answers: the program's ``text``, its attachment ``filename``, its
    ``media_type`` and ``details`` (steps, waypoints, IK solves, worst errors, seconds)."""

    text: str
    filename: str
    media_type: str
    details: dict

    @property
    def headers(self) -> dict:
        """The answer's headers: the attachment's name and the check's figures."""
        return {"Content-Disposition": f'attachment; filename="{self.filename}"',
                PROGRAM_DETAILS_HEADER: json.dumps(self.details, separators=(",", ":"))}


def _floats(value, where: str = "plan"):
    """The plan document with its decimals as floats (the plan's numbers are floats: poses,
    scores); a decimal beyond a float's range is a ``BadRequest``."""
    if isinstance(value, Decimal):
        f = float(value)
        if not math.isfinite(f):
            raise BadRequest(400, f"{where}: number {value} is out of range")
        return f
    if isinstance(value, dict):
        return {k: _floats(v, where) for k, v in value.items()}
    if isinstance(value, list):
        return [_floats(v, where) for v in value]
    return value


def _cell(raw) -> Cell:
    if raw is None:
        return Cell()
    if not isinstance(raw, str):
        raise BadRequest(400, "cell: must be a cell file's TOML text (a string), e.g. "
                              "\"[assembly]\\nposition_m = [0.45, 0.1]\"")
    try:
        return cell_from_toml(raw, "cell")
    except InputError as exc:
        raise BadRequest(400, str(exc)) from None


def parse_export_request(body: bytes, *, max_parts: int = LIMITS.max_parts,
                         max_vertices: int = ServeConfig.max_vertices) -> ExportRequest:
    """The ``ExportRequest`` of a ``POST /export`` body, or ``BadRequest`` (module doc)."""
    doc = request_object(body, EXPORT_KEYS,
                         '{"assembly": {...}, "plan": {...}, "format": "urscript"}')
    for key, what in (("assembly", "the assembly JSON object"),
                      ("plan", "the plan document POST /plan answered")):
        if key not in doc:
            raise BadRequest(400, f"missing key {key!r} ({what})")
    cell = _cell(doc.get("cell"))
    arm = doc.get("arm", cell.robot.arm)
    fmt = doc.get("format")
    try:
        if not isinstance(arm, str):
            raise InputError(f"arm {arm!r}: choose one of {', '.join(ARMS)}")
        cell = with_(cell, "robot", arm=arm_spec(arm).name)
        if fmt is None:
            fmt = arm_spec(arm).formats[0]
        if not isinstance(fmt, str):
            raise InputError(f"format {fmt!r}: choose one of {', '.join(EXPORT_FORMATS)}")
        check_format(arm, fmt)
    except InputError as exc:
        raise BadRequest(400, str(exc)) from None
    assembly = request_assembly(doc["assembly"], max_parts, max_vertices)
    try:
        plan = plan_of(_floats(doc["plan"]), "plan")
        check_assembly(plan, assembly, "assembly")
    except InputError as exc:
        raise BadRequest(400, str(exc)) from None
    problem = is_assembly_order(plan.steps, assembly.ids)
    if problem is not None:
        raise BadRequest(400, f"plan: {problem}: not a plan of this assembly")
    return ExportRequest(assembly, plan, fmt, cell)


def _stem(name: str) -> str:
    return re.sub(r"[^\w.-]+", "_", name, flags=re.ASCII).strip("._")[:100] or "program"


def program_file(req: ExportRequest) -> ProgramFile:
    """The program of ``req``, checked by the arm's kinematics (module doc). Raises
    ``BadRequest``: 422 for a plan one arm cannot build or a step out of reach, 400 for no
    place for the cup."""
    from rap.robot.arms.export import export_text
    from rap.robot.kinematics import Unreachable
    from rap.robot.program import TwoHandedPlan, build_program

    try:
        program = build_program(req.plan, req.assembly, req.cell)
        text, report = export_text(program, req.format)
    except (TwoHandedPlan, Unreachable) as exc:
        raise BadRequest(422, str(exc)) from None
    except InputError as exc:
        raise BadRequest(400, str(exc)) from None
    ending, media = EXPORT_FORMATS[req.format]
    details = {"format": req.format, "steps": len(program.steps),
               "waypoints": len(program.waypoints), "fixture": program.fixture,
               "plane": program.frame.plane, "arm": program.cell.robot.arm,
               "branch": report.branch, "solves": report.solves,
               "worst_position_m": report.worst_position_m,
               "worst_angle_rad": report.worst_angle_rad, "check_seconds": report.seconds}
    return ProgramFile(text, _stem(req.plan.assembly) + ending, media, details)


# -- the request body in the OpenAPI document (the endpoint reads the raw body itself) ----------
EXPORT_OPENAPI = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": {
            "type": "object", "required": ["assembly", "plan"], "additionalProperties": False,
            "properties": {
                "assembly": {"type": "object", "description": "The assembly JSON, as POST /plan "
                             "takes it"},
                "plan": {"type": "object", "description": "The plan document POST /plan "
                         "answered (`rap-farm plan --out`), made with a fixture (constraints."
                         "base) and one part per step (constraints.linear)"},
                "arm": {"type": "string", "enum": list(ARMS), "description": "The arm "
                        "(default: the cell's [robot] arm, panda in the shipped cell)"},
                "format": {"type": "string", "enum": list(EXPORT_FORMATS), "description":
                           "One the arm takes (urscript: UR arms; joint-trajectory-yaml|json: "
                           "the Panda; waypoints-csv|json: any); default the arm's first"},
                "cell": {"type": "string", "description": "A cell file's TOML text (docs/ROBOT.md"
                         "); default: the shipped cell, rap/robot/default_cell.toml"}}}}},
    },
    "responses": {"200": {"description": "The program as an attachment: URScript "
                                         "(ASSEMBLY.script), a joint trajectory (ASSEMBLY-"
                                         "trajectory.yaml, .json) or waypoints (ASSEMBLY-"
                                         "waypoints.csv, .json); the header X-Program-Details "
                                         "carries the kinematic check's figures"},
                  "400": {"description": "Malformed request, invalid assembly, plan or cell, an "
                                         "unknown arm, a format unknown or not the arm's"},
                  "401": {"description": "Missing or wrong bearer token"},
                  "413": {"description": "Body or assembly too large"},
                  "422": {"description": "A plan one arm cannot build (a two-handed step needs a "
                                         "second fixture), or a step out of the arm's reach"},
                  "503": {"description": "Reading or the program past its time budget"}},
}
