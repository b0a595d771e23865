"""The planning service's contract, without ray or fastapi: its settings and its request parser.

Every request's work is bounded: the assembly within ``rap.assembly.LIMITS`` (coordinates,
vertices, holes; checked on the numbers' text before any arithmetic), at most ``max_parts`` parts (``max_optimal_parts`` for the
optimum, whose search visits every reachable subassembly), ``max_simulations`` fresh simulations
and a time budget, the request's ``budget_s`` (``rap.serve.budget``: anytime for the search, hard
for the others: a ``"feasible": null, "status": "budget spent"`` answer). Reading and validating
take at most ``parse_budget_s`` and the whole answer at most ``budget_s + answer_grace_s``; past
either the service answers 503 (``rap.serve.http_app`` runs both off its event loop).

``ServeConfig`` holds every setting of ``rap-farm serve`` (``check()`` refuses, in one line, what
must not start: a non-loopback host without a bearer token, a short token, a bad port).
``parse_plan_body(body)`` turns a ``POST /plan`` body into a ``PlanBody`` (assembly, method, root
seed, planner options, cell constraints, budget) or raises ``BadRequest(status, one line)``
(``parse_plan_request``: its first five as a tuple); the options (``PLANNER_OPTIONS``)
are those of ``rap-farm plan`` for the method asked for (search: ``simulations``, at most
``max_simulations``, ``trust``, ``optimism``, ``beam_width``; rap: ``fallback_k``,
``high_probability``, ``fallback_optimism``); numbers are parsed as decimals, exactly as
``rap.io.load_assembly`` reads a file, and an invalid assembly gets the CLI's
``AssemblyError`` text with ``assembly`` as its source. The optional ``constraints`` object is the
robot cell's (``rap.plan.cell.constraints.CellConstraints.from_json``: ``{"base": "plate", "linear":
true, "directions": ["0,-1:30"], "gravity": "0,-1", "friction": 0.5, "layers": true}``), checked as the CLI's
flags are (one-line 400 naming ``constraints.KEY``; the base must be a part of the assembly). ``read_upload(name, body)`` reads an
uploaded file (``POST /import``, ``/inspect``): a drawing (.dxf, .svg) or an assembly file (.json),
written under its own name in a temporary directory and read by ``rap.io.load_assembly``, which
chooses the reader by the suffix; its errors name the file as the client did. ``rap.serve.http_app``
serves them over HTTP.
"""

from __future__ import annotations

import ipaddress
import json
import re
import tempfile
from dataclasses import asdict, dataclass, replace
from decimal import Decimal, InvalidOperation
from pathlib import Path

from rap.assembly import LIMITS, Assembly, AssemblyError, json_error_reason
from rap.io import load_assembly, parse_assembly
from rap.errors import InputError, ParameterError
from rap.plan.cell.help import CELL_HELP
from rap.plan.cell.constraints import CellConstraints
from rap.plan.methods import DEFAULT_METHOD, METHODS, service_options
from rap.seeds import DEFAULT_ROOT_SEED
from rap.serve.budget import read_budget_s

__all__ = ["ServeConfig", "BadRequest", "PlanBody", "parse_plan_body", "parse_plan_request",
           "read_upload", "is_loopback",
           "PLAN_BODY_OPENAPI", "UPLOAD_OPENAPI", "UPLOAD_NAME_HELP",
           "REQUEST_KEYS", "DETAILS_HEADER", "PLANNER_OPTIONS", "UPLOAD_SUFFIXES"]

REQUEST_KEYS = ("assembly", "method", "seed", "options", "constraints", "budget_s", "rollouts",
                "perturbed_candidate")
# option -> (methods it applies to, kind, low, high, low inclusive): make_planner's keywords, as
# the methods declare them (rap.plan.methods), for the API's schema
PLANNER_OPTIONS = {name: (methods, opt.kind, opt.low, opt.high, not opt.low_open)
                   for name, (opt, methods) in service_options().items()}
UPLOAD_SUFFIXES = (".dxf", ".svg", ".json")  # what POST /import and /inspect read
DETAILS_HEADER = "X-Plan-Details"  # {"eval_seconds", "stats"} of an answered plan (rap.client)


@dataclass(frozen=True)
class ServeConfig:
    """Every setting of the service. ``token`` is never part of ``to_dict()``."""

    host: str = "127.0.0.1"
    port: int = 8000
    model_path: str | None = None  # None: plan without a CNN (method rap is refused)
    workers: int | None = None  # simulation actors; None: every CPU of the cluster
    cache_path: str | None = None  # score cache file; None: memory only
    token: str | None = None
    engine: str = "auto"  # the CNN's scorer (OperationPredictor.load): the CLI's default
    trials: int = 100  # simulator trials per operation
    max_body_bytes: int = 1 << 20
    # every assembly the input bounds allow (rap.assembly.LIMITS): a large one is bounded by its
    # request's budget (the search answers its best plan by then) and max_simulations, not refused
    max_parts: int = LIMITS.max_parts
    max_vertices: int = 20_000  # in all; the worst-case validation stays within parse_budget_s
    max_optimal_parts: int = 16  # the optimum's search visits every reachable subassembly
    max_simulations: int = 2000  # fresh simulations of one request's search
    max_concurrent: int = 16  # requests planned at once
    # a request's time budget when it names none: a page user waits a minute or two, and the
    # default plans a 100-part drawing in 55-68 s on 2 CPUs (docs/SERVICE.md)
    request_budget_s: float = 120.0
    plan_budget_s: float = 600.0  # the most a request's budget_s may be
    eval_share: float = 0.25  # of the budget kept from the search for the evaluation and answer
    parse_budget_s: float = 10.0  # reading and validating one request's assembly (off the loop)
    answer_grace_s: float = 30.0  # past the request's budget_s + this, it is answered 503
    cache_flush_s: float = 30.0  # write the cache file at most this often

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("token")
        d["auth"] = "bearer" if self.token else "none"
        return d

    def check(self) -> None:
        """Raise ``InputError`` (one line) for a configuration that must not start."""
        if not 0 < self.port < 65536:
            raise InputError(f"--port {self.port}: choose 1..65535")
        if not 0 < self.request_budget_s <= self.plan_budget_s:
            raise InputError(f"--budget {self.request_budget_s:g}: choose a number of seconds in "
                             f"(0, {self.plan_budget_s:g}]")
        if self.engine not in ("auto", "cnn", "torch"):
            raise InputError(f"--engine {self.engine!r}: choose auto, cnn or torch")
        if self.token is not None and len(self.token) < 16:
            raise InputError("--token: use at least 16 characters (e.g. python -c 'import secrets; "
                             "print(secrets.token_urlsafe(32))')")
        if not is_loopback(self.host) and not self.token:
            raise InputError(f"--host {self.host}: serving beyond this machine needs a bearer "
                             f"token; pass --token or set RAP_FARM_TOKEN")


def is_loopback(host: str) -> bool:
    """Whether ``host`` names only this machine (127.0.0.0/8, ::1, localhost)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


class BadRequest(Exception):
    """A request the service refuses: HTTP ``status`` and a one-line ``message``."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


def _reject_constant(name: str):
    raise ValueError(f"non-finite number {name} is not allowed")


def _planner_options(raw, method: str, max_simulations: int) -> dict:
    """The ``options`` object of a request, checked by the method's declarations
    (``rap.plan.methods``; ``PLANNER_OPTIONS``)."""
    if not isinstance(raw, dict):
        raise BadRequest(400, "options must be a JSON object, e.g. {\"simulations\": 200, "
                              "\"optimism\": 0.1}")
    accepted = service_options()
    declared = {o.name: o for o in METHODS[method].declared() if o.service}
    out = {}
    for key, value in raw.items():
        if key not in accepted:
            raise BadRequest(400, f"options: unknown option {key!r} (expected "
                                  f"{', '.join(accepted)})")
        opt = declared.get(key)
        if opt is None:
            raise BadRequest(400, f"options.{key} applies to method "
                                  f"{' or '.join(accepted[key][1])}, not {method!r}")
        ok_type = (isinstance(value, int) if opt.kind is int
                   else isinstance(value, (int, Decimal))) and not isinstance(value, bool)
        if not ok_type:
            raise BadRequest(400, f"options.{key} {value!r}: must be "
                                  f"{'an integer' if opt.kind is int else 'a number'}")
        v = opt.kind(value)
        try:
            opt.check(v)
        except ParameterError:
            span = (f"lie in {'(' if opt.low_open else '['}{opt.low}, {opt.high}]"
                    if opt.high is not None else f"be >= {opt.low}")
            raise BadRequest(400, f"options.{key} {v}: must {span}") from None
        out[key] = v
    if out.get("simulations", 0) > max_simulations:
        raise BadRequest(413, f"options.simulations {out['simulations']}: this service allows at "
                              f"most {max_simulations} per request")
    return out


def _constraints(raw) -> CellConstraints:
    """The request's ``constraints`` object, or a one-line 400 naming ``constraints.KEY``."""
    try:
        return CellConstraints.from_json(raw)
    except ParameterError as exc:
        name = "constraints" if exc.parameter == "constraints" else f"constraints.{exc.parameter}"
        raise BadRequest(400, exc.for_name(name)) from None


def request_object(body: bytes, keys, shape: str, depth_note: str = "") -> dict:
    """A request body as a JSON object whose keys are among ``keys`` (numbers as exact
    ``Decimal``/``int``, no NaN or Infinity), else ``BadRequest`` 400 with one line (``shape``:
    the object expected, in words)."""
    try:
        doc = json.loads(body, parse_float=Decimal, parse_int=int,
                         parse_constant=_reject_constant)
    except RecursionError:
        raise BadRequest(400, f"request body is nested too deeply{depth_note}") from None
    except (ValueError, InvalidOperation) as exc:
        raise BadRequest(400, f"request body is not valid JSON: {json_error_reason(exc)}") from None
    if not isinstance(doc, dict):
        raise BadRequest(400, f"request body must be a JSON object {shape}")
    unknown = sorted(set(doc) - set(keys))
    if unknown:
        raise BadRequest(400, f"unknown key {unknown[0]!r} (expected {', '.join(keys)})")
    return doc


def request_assembly(raw, max_parts: int, max_vertices: int) -> Assembly:
    """A request's ``assembly`` object, read exactly within the service's bounds: ``BadRequest``
    413 past ``max_parts`` parts (counted before any arithmetic), 400 for an invalid one (the
    reader's line)."""
    parts = raw.get("parts") if isinstance(raw, dict) else None
    if isinstance(parts, list) and len(parts) > max_parts:
        raise BadRequest(413, f"assembly: {len(parts)} parts; this service reads at most "
                              f"{max_parts}")
    try:
        return parse_assembly(raw, source="assembly", default_name="assembly",
                              limits=replace(LIMITS, max_vertices=max_vertices))
    except AssemblyError as exc:
        raise BadRequest(400, str(exc)) from None
    except RecursionError:
        raise BadRequest(400, "assembly: nested too deeply") from None


@dataclass(frozen=True)
class PlanBody:
    """A ``POST /plan`` body, read and checked (``parse_plan_body``). ``budget_s``: the request's
    time budget in seconds (its own, else the service's default)."""

    assembly: Assembly
    method: str
    seed: int
    options: dict
    constraints: CellConstraints
    budget_s: float
    rollouts: bool = True
    perturbed: bool = False  # the request's perturbed_candidate


def parse_plan_body(body: bytes, *, max_parts: int = LIMITS.max_parts, max_optimal_parts: int = 16,
                    max_simulations: int = 2000, max_vertices: int = 20_000,
                    default_budget_s: float = ServeConfig.request_budget_s,
                    max_budget_s: float = ServeConfig.plan_budget_s) -> PlanBody:
    """The ``PlanBody`` of a ``POST /plan`` body, or ``BadRequest``."""
    doc = request_object(body, REQUEST_KEYS, '{"assembly": {...}, "method": ..., "seed": ...}',
                         " (a plan request needs 6 levels)")
    if "assembly" not in doc:
        raise BadRequest(400, "missing key 'assembly' (the assembly JSON object)")
    method = doc.get("method", DEFAULT_METHOD)
    if not isinstance(method, str) or method not in METHODS:
        raise BadRequest(400, f"method {method!r}: choose one of {', '.join(METHODS)}")
    seed = doc.get("seed", DEFAULT_ROOT_SEED)
    if isinstance(seed, bool) or not isinstance(seed, int) or not -(1 << 63) <= seed < (1 << 63):
        raise BadRequest(400, f"seed {seed!r}: must be an integer in [-2^63, 2^63)")
    options = _planner_options(doc.get("options", {}), method, max_simulations)
    try:
        budget_s = read_budget_s(doc.get("budget_s"), default_budget_s, max_budget_s)
    except ValueError as exc:
        raise BadRequest(*exc.args) from None
    constraints = _constraints(doc.get("constraints", {}))
    rollouts = doc.get("rollouts", True)
    if not isinstance(rollouts, bool):
        raise BadRequest(400, f"rollouts {rollouts!r}: must be true or false")
    perturbed = doc.get("perturbed_candidate", False)
    if not isinstance(perturbed, bool):
        raise BadRequest(400, f"perturbed_candidate {perturbed!r}: must be true or false")
    if perturbed and not (rollouts and method == "search"):
        raise BadRequest(400, "perturbed_candidate: the search with rollouts only (method "
                              "'search', rollouts true)")
    assembly = request_assembly(doc["assembly"], max_parts, max_vertices)
    if method == "optimal" and len(assembly) > max_optimal_parts:
        raise BadRequest(413, f"method 'optimal': {len(assembly)} parts; this service finds the "
                              f"optimum for at most {max_optimal_parts} (ask for rap or sim)")
    try:
        constraints.check(assembly)
    except ParameterError as exc:
        raise BadRequest(400, exc.for_name("constraints.base")) from None
    return PlanBody(assembly, method, int(seed), options, constraints, budget_s, rollouts,
                    perturbed)


def parse_plan_request(body: bytes, **limits):
    """(assembly, method, root seed, planner options, ``CellConstraints``) of a ``POST /plan``
    body (``parse_plan_body``'s first five), or ``BadRequest``."""
    got = parse_plan_body(body, **limits)
    return got.assembly, got.method, got.seed, got.options, got.constraints


def _upload_name(name: str | None) -> str:
    """``name`` as a plain file name (its last path component; characters other than letters,
    digits, ``._-`` and spaces become ``_``), or ``BadRequest`` without a known suffix."""
    base = re.sub(r"[^\w. -]", "_", str(name or "").replace("\\", "/").rsplit("/", 1)[-1],
                  flags=re.ASCII).strip(" .")[-100:]
    suffix = Path(base).suffix.lower()
    if not base or suffix not in UPLOAD_SUFFIXES or base.lower() == suffix:
        what = f"name {name!r}" if name else "no name"
        raise BadRequest(400, f"{what}: give the file's name, ending in "
                              f"{', '.join(UPLOAD_SUFFIXES)} (e.g. ?name=part.dxf)")
    return base


def read_upload(name: str | None, body: bytes, *, max_parts: int = LIMITS.max_parts,
                max_vertices: int = 20_000) -> Assembly:
    """The validated assembly of an uploaded file named ``name`` (its suffix chooses the reader:
    ``rap.io.load_assembly`` on a copy written under that name, so that an assembly without a
    ``name`` is called after the file's stem), or ``BadRequest``: 400 with the reader's one line
    (the temporary path replaced by ``name``), 413 past ``max_parts`` parts or ``max_vertices``
    vertices in all."""
    base = _upload_name(name)
    with tempfile.TemporaryDirectory(prefix="rap-upload-") as tmp:
        path = Path(tmp) / base
        path.write_bytes(body)
        try:
            assembly = load_assembly(path)
        except InputError as exc:  # AssemblyError and the drawing readers' errors: one line
            raise BadRequest(400, str(exc).replace(str(path), base)) from None
        except RecursionError:
            raise BadRequest(400, f"{base}: nested too deeply") from None
    if len(assembly) > max_parts:
        raise BadRequest(413, f"{base}: {len(assembly)} parts; this service plans at most "
                              f"{max_parts}")
    vertices = sum(len(p.outer) + sum(map(len, p.holes)) for p in assembly.parts)
    if vertices > max_vertices:
        raise BadRequest(413, f"{base}: {vertices} vertices; this service reads at most "
                              f"{max_vertices} in all")
    return assembly


# -- the request bodies in the OpenAPI document (the endpoints read the raw body themselves) ---
PLAN_BODY_OPENAPI = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": {
            "type": "object", "required": ["assembly"], "additionalProperties": False,
            "properties": {
                "assembly": {"type": "object", "description": "An assembly file's JSON: "
                             "{\"name\": ..., \"parts\": [{\"id\", \"polygon\", \"holes\"}]}"},
                "method": {"type": "string", "enum": list(METHODS), "default": DEFAULT_METHOD},
                "seed": {"type": "integer", "description": "Root seed of the simulator's "
                         "randomness", "default": DEFAULT_ROOT_SEED},
                "rollouts": {"type": "boolean", "default": True,
                             "description": "Measure the found plan's sequence success by "
                             "rollouts on the simulation pool under the shipped cell's errors "
                             "(and, for the search, choose among its 3 best plans by it): "
                             "`sequence_success` and each step's `execution`"},
                "perturbed_candidate": {"type": "boolean", "default": False,
                                        "description": "With rollouts, the search: its choice "
                                        "also measures the best plan on perturbed-start scores "
                                        "(every operation simulated once with the placed parts "
                                        "where rollouts leave them; `rap-farm plan "
                                        "--perturbed-candidate`)"},
                "budget_s": {"type": "number", "exclusiveMinimum": 0,
                             "description": "The request's time budget in seconds (default "
                             "and cap: the service's, 120 and 600 unless set otherwise). The "
                             "search answers the best plan found within it (it stops simulating "
                             "at 75% of it, leaving the rest for the plan's evaluation); other "
                             "methods answer \"budget spent\" past it"},
                "options": {"type": "object", "additionalProperties": False,
                            "description": "The method's options, as `rap-farm plan`'s "
                            "(search: simulations, trust, optimism, beam_width; rap: "
                            "fallback_k, high_probability, fallback_optimism), e.g. {\"simulations\": 200, "
                            "\"optimism\": 0.1}",
                            "properties": {k: {"type": "integer" if kind is int else "number"}
                                           for k, (_, kind, *_rest) in PLANNER_OPTIONS.items()}},
                "constraints": {
                    "type": "object", "additionalProperties": False,
                    "description": "The robot cell's constraints, as `rap-farm plan`'s --base, "
                    "--linear, --directions, --gravity, --friction, --layers, e.g. {\"base\": \"plate\", "
                    "\"linear\": true, \"directions\": [\"0,-1:30\"], \"gravity\": \"0,-1\"}",
                    "properties": {
                        "base": {"type": "string", "description": CELL_HELP["base"]},
                        "linear": {"type": "boolean", "description": CELL_HELP["linear"]},
                        "directions": {"type": "array", "items": {"type": "string"},
                                       "description": CELL_HELP["directions"]},
                        "gravity": {"type": "string", "description": CELL_HELP["gravity"]},
                        "friction": {"type": "number", "minimum": 0, "default": 0.5,
                                     "description": CELL_HELP["friction"]},
                        "layers": {"type": "boolean", "description": CELL_HELP["layers"]}}}}}}},
    },
    "responses": {"200": {"description": "The plan (the `rap-farm plan --out` document: units, "
                                         "R and its interval, steps with insertion, score "
                                         "interval, reason and robot poses; README, Plan files)"},
                  "400": {"description": "Malformed request or invalid assembly"},
                  "401": {"description": "Missing or wrong bearer token"},
                  "413": {"description": "Body or assembly too large, or budget_s over the "
                                         "service's cap"},
                  "503": {"description": "Reading or planning past the request's time budget"}},
}


UPLOAD_OPENAPI = {
    "requestBody": {
        "required": True,
        "content": {"application/octet-stream": {"schema": {
            "type": "string", "format": "binary",
            "description": "The file's bytes, as they are on disk: a drawing (.dxf, .svg) or an "
                           "assembly file (.json); the suffix of `name` says which"}}},
    },
    "responses": {"400": {"description": "No or unknown `name`, or a bad drawing or assembly "
                                         "(one line naming the entity or part and the problem)"},
                  "401": {"description": "Missing or wrong bearer token"},
                  "413": {"description": "Body or assembly too large"},
                  "503": {"description": "Reading (or, for /inspect, the NDBG) past its time "
                                         "budget"}},
}
UPLOAD_NAME_HELP = f"The file's name; its suffix ({', '.join(UPLOAD_SUFFIXES)}) chooses the reader"
