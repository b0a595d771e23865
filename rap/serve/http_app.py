"""The planning service over HTTP: a Ray Serve application with a FastAPI ingress (``rap-farm serve``).

One Serve replica, ``PlanningApp``, holds a ``rap.serve.planning.PlanningService``: the CNN loaded
once, one content-keyed score cache, and a ``SimPool`` of simulation actors (one per CPU of the Ray
cluster unless ``workers``), all kept warm between requests. The replica asks for no CPU itself and
runs on the head node, like Serve's HTTP proxy (``proxy_location="HeadOnly"``): on a cluster the
service listens on ``host:port`` of the head node and the cache file lives there.

Endpoints (OpenAPI document at ``/openapi.json``, interactive docs at ``/docs`` and ``/redoc``,
whose Swagger UI and ReDoc files come from the fastapi-offline package, not a CDN: they work
offline):

* ``GET /``: the planning page (``rap/serve/static``: plain HTML, CSS and JS, no build step, no
  other host): choose or drop a drawing or assembly file, see its parts and NDBG circle, plan with
  a method, a seed and optionally the robot cell's constraints through ``POST /plan``, step
  through the plan as a storyboard, download the plan JSON and the storyboard (PNG or SVG), or
  try a shipped example with one click. Its requests carry the token typed in the page.
* ``GET /examples``: ``[{"name", "parts"}]``, the example assemblies shipped in the package;
  ``GET /examples/{name}``: one's assembly JSON, 404 for another name (``rap.serve.examples``).
* ``GET /health``: 200 ``{"status": "ok", ...}`` once the model is loaded and every simulation
  actor has started (before that, Serve answers 503 or the connection is refused).
* ``POST /plan``: body ``{"assembly": <assembly JSON object>, "method": "rap"|"sim"|"optimal"|
  "random"|"search" (default "search"), "seed": <int> (optional), "options": {...} (optional: the
  method's planner options, ``rap.serve.api.PLANNER_OPTIONS``), "constraints": {...} (optional: the
  robot cell's, ``rap.plan.cell.constraints.CellConstraints.from_json``)}``. 200 with exactly the document that
  ``rap-farm plan --out`` writes (``PlanResult.to_json()``): ``"feasible": true`` with the steps, or
  ``"feasible": false`` with the interlocked parts (an interlocked assembly is a valid question),
  or ``"feasible": null`` when the request's budget (``"budget_s"``: ``rap.serve.budget``) ran
  out. ``X-Plan-Details`` carries ``{"eval_seconds", "stats"}`` (what ``plan --server`` prints).
* ``POST /import?name=FILE``: the body is a file's bytes, a drawing (``.dxf``, ``.svg``) or an
  assembly file (``.json``), read by ``rap.io.load_assembly`` as the CLI reads it
  (``rap.serve.api.read_upload``); 200 with its assembly JSON (what ``rap-farm import`` writes).
* ``POST /inspect?name=FILE``: the same, and its NDBG: ``{"assembly": <assembly JSON>, "cells":
  [{"kind", "direction", "partitions"}]}`` (``inspect_document``), what the page draws.
* ``POST /export``: a plan's checked robot program as an attachment (``rap.serve.robot_program``).

Bad requests get a 4xx status and ``{"error": "<one line>"}``: 400 for a body that is not JSON or
not an object of those keys, an invalid assembly (the one-line ``AssemblyError`` text of the CLI,
with ``assembly`` as the source), an unknown method or a seed that is not an integer; 413 for a
body over ``max_body_bytes`` or an assembly of more than ``max_parts`` parts (``max_optimal_parts``
for method optimal); 401 without the bearer token when one is set; 503 when reading the assembly
(or an uploaded file) takes over ``parse_budget_s`` or the answer (or ``/inspect``'s NDBG) over
``budget_s + answer_grace_s``. A bad upload (no ``name`` or another suffix, a bad drawing or
assembly) is a 400 with the reader's one line, naming the file as the client did. Numbers are
parsed as decimals, exactly as ``load_assembly`` reads a file, within ``rap.assembly.LIMITS``.
Reading, validating and planning run on threads, never on the event loop, so ``/health`` answers
throughout. A 500 is only for the service's own faults (a bug), with one line; the replica keeps
serving.

Concurrency: each request is planned on one of ``max_concurrent`` threads of the replica; the
requests' simulation batches go to the shared pool at the same time (``SimPool`` keeps its
bookkeeping thread-safe), CNN forward passes take turns. Further requests wait in Serve's queue.

The request contract (``ServeConfig``, ``parse_plan_request``) lives in ``rap.serve.api``, which
imports neither ray nor fastapi. This module is the replica and its endpoints; the FastAPI
application with the routes that need no replica (the page, the examples, the one-line errors) is
``rap.serve.http_api``, and how a request is taken (token, body within its limit, work on a thread
within a budget) is ``rap.serve.http_requests``.

Running it: ``rap.serve.launch.run_service``. Security: ``run_service`` refuses a non-loopback ``host`` without a token (``ServeConfig.check``);
with a token every endpoint but the documentation, the page's static files and the examples needs
``Authorization: Bearer <token>`` (the page sends it on each of its requests). The token
travels in clear text over plain HTTP: beyond one machine, put the service behind TLS (a reverse
proxy) or on a private network, as docs/CLUSTER.md says.
"""

# No "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time,
# and Serve rebuilds the class-based routes where string annotations do not resolve.

import json
import logging
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path

from fastapi import Query, Request, Security
from fastapi.responses import JSONResponse, Response
from fastapi.security import HTTPAuthorizationCredentials
from ray import serve

from rap import __version__
from rap.assembly import Assembly, assembly_to_json
from rap.plan.methods import needs_model

from rap.serve.api import (DETAILS_HEADER, PLAN_BODY_OPENAPI, UPLOAD_NAME_HELP, UPLOAD_OPENAPI,
                          BadRequest, ServeConfig, parse_plan_body, read_upload)
from rap.serve.budget import request_limits
from rap.serve import robot_program
from rap.serve.http_api import STATIC_DIR, api, inspect_document
from rap.serve.http_requests import authorised, bearer, off_loop, read_body

__all__ = ["PlanningApp", "build_app", "inspect_document", "APP_NAME", "STATIC_DIR",
           "STOP_GRACE_S"]

APP_NAME = "rap-farm"
STOP_GRACE_S = 30.0  # on stop (SIGTERM, Ctrl-C), requests in flight get this long to finish
_log = logging.getLogger("rap.serve.http_app")


#: the replica asks for no CPU and stays on the head node, next to the HTTP proxy (HeadOnly) and the
#: score cache file; its simulation actors spread over the cluster
_HEAD = "node:__internal_head__"


@serve.deployment(name="planner", num_replicas=1,
                  ray_actor_options={"num_cpus": 0, "resources": {_HEAD: 0.001}},
                  max_ongoing_requests=64)
@serve.ingress(api)
class PlanningApp:
    """The replica (see module doc). ``config``: ``ServeConfig`` fields as a dict."""

    def __init__(self, config: dict):
        from rap.serve.planning import PlanningService
        from rap.sim.params import SimParams

        self.config = ServeConfig(**config)
        self.params = SimParams(trials=self.config.trials)
        self.service = PlanningService(self.config.model_path, workers=self.config.workers,
                                       cache_path=self.config.cache_path,
                                       engine=self.config.engine)
        if self.service.pool is not None:
            self.service.pool.ready(timeout_s=600)
        self._executor = ThreadPoolExecutor(self.config.max_concurrent,
                                            thread_name_prefix="plan")
        self._readers = ThreadPoolExecutor(4, thread_name_prefix="read")
        self._flush_lock = threading.Lock()
        self._flushed = time.monotonic()
        self.served = 0

    # -- helpers -------------------------------------------------------------------------------------
    def _authorised(self, creds: HTTPAuthorizationCredentials | None) -> JSONResponse | None:
        """None when the request carries this service's token (or it has none), else the 401."""
        return authorised(self.config.token, creds)

    def _read(self, body: bytes):
        """``parse_plan_body`` with this service's limits (runs on a reader thread)."""
        c = self.config
        parsed = parse_plan_body(body, max_parts=c.max_parts, max_optimal_parts=c.max_optimal_parts,
                                 max_simulations=c.max_simulations, max_vertices=c.max_vertices,
                                 default_budget_s=c.request_budget_s, max_budget_s=c.plan_budget_s)
        if needs_model(parsed.method) and self.service.cnn is None:
            raise BadRequest(400, f"method {parsed.method!r}: this service has no CNN model; ask "
                                  f"for method sim")
        return parsed

    def _read_upload(self, name: str | None, body: bytes) -> Assembly:
        """``read_upload`` with this service's limits (runs on a reader thread)."""
        return read_upload(name, body, max_parts=self.config.max_parts,
                           max_vertices=self.config.max_vertices)

    async def _read_request(self, request: Request, creds: HTTPAuthorizationCredentials | None,
                            what: str, fn, *args):
        """Check the token, take the body (at most ``max_body_bytes``) and read it with
        ``fn(*args, body)`` on a reader thread within ``parse_budget_s``: its value, or the answer
        to send instead (``what`` names the thing read in the 503 and 500 lines)."""
        denied = self._authorised(creds)
        if denied is not None:
            return denied
        body = await read_body(request, self.config.max_body_bytes)
        if isinstance(body, JSONResponse):
            return body
        budget = self.config.parse_budget_s
        return await off_loop(self._readers, budget, f"{what} was not read and validated "
                              f"within {budget:g} s; send a smaller one", f"reading {what}",
                              fn, *args, body)

    def _plan(self, body, arrived: float):
        """Plan ``body`` (a ``PlanBody``) within what is left of its budget (``rap.serve.budget``)."""
        from rap.serve.planning import PlanRequest

        options, budget = request_limits(body, arrived, self.config)
        req = PlanRequest(body.assembly, body.method, self.params, body.seed, budget=budget,
                          planner_options=options, constraints=body.constraints,
                          rollouts=body.rollouts, perturbed=body.perturbed)
        result = self.service.plan(req)
        self._maybe_flush()
        return result

    def _maybe_flush(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._flushed < self.config.cache_flush_s:
            return
        if self._flush_lock.acquire(blocking=force):
            try:
                self._flushed = now
                self.service.flush()
            except OSError as exc:  # a full disk costs the cache, not the service
                _log.warning("score cache not written: %s", exc)
            finally:
                self._flush_lock.release()

    # -- endpoints ------------------------------------------------------------------------------------
    @api.get("/health", summary="Ready to plan")
    async def health(self, creds: HTTPAuthorizationCredentials | None = Security(bearer)):
        denied = self._authorised(creds)
        if denied is not None:
            return denied
        info = self.service.ready()
        model = Path(info["model"]).name if info["model"] else None
        return {"status": "ok", "version": __version__, "model": model, "workers": info["pool"],
                "cached_scores": info["cached_scores"], "trials": self.config.trials,
                "served": self.served, "peak_concurrent": self.service.peak_concurrency()}

    @api.post("/plan", summary="Plan a robust assembly sequence", openapi_extra=PLAN_BODY_OPENAPI)
    async def plan(self, request: Request,
                   creds: HTTPAuthorizationCredentials | None = Security(bearer)):
        arrived = time.monotonic()  # the request's budget counts from here
        # reading and exact validation run off the event loop: /health keeps answering
        read = await self._read_request(request, creds, "the assembly", self._read)
        if isinstance(read, JSONResponse):
            return read
        left = read.budget_s + self.config.answer_grace_s - (time.monotonic() - arrived)
        result = await off_loop(
            self._executor, max(left, 1e-3),
            f"planning took longer than its budget of {read.budget_s:g} s; ask with a larger "
            f"budget_s or fewer simulations", f"planning {read.assembly.name} with {read.method}",
            self._plan, read, arrived)
        if isinstance(result, JSONResponse):
            return result
        self.served += 1
        details = json.dumps({"eval_seconds": result.eval_seconds, "stats": result.stats},
                             default=str, separators=(",", ":"))
        return JSONResponse(result.to_json(), headers={DETAILS_HEADER: details})

    @api.post("/import", summary="An assembly from a drawing (DXF, SVG) or an assembly file",
              openapi_extra=UPLOAD_OPENAPI)
    async def import_drawing(self, request: Request,
                             name: str | None = Query(None, description=UPLOAD_NAME_HELP),
                             creds: HTTPAuthorizationCredentials | None = Security(bearer)):
        """The body is the file's bytes; 200 with the assembly JSON that ``rap-farm import``
        writes (read exactly, validated), ready for ``POST /plan``."""
        got = await self._read_request(request, creds, str(name), self._read_upload, name)
        return got if isinstance(got, JSONResponse) else JSONResponse(assembly_to_json(got))

    @api.post("/inspect", summary="A drawing's or assembly file's parts and NDBG cells",
              openapi_extra=UPLOAD_OPENAPI)
    async def inspect(self, request: Request,
                      name: str | None = Query(None, description=UPLOAD_NAME_HELP),
                      creds: HTTPAuthorizationCredentials | None = Security(bearer)):
        """As ``/import``, and the NDBG: 200 with ``{"assembly": <assembly JSON>, "cells":
        [{"kind", "direction", "partitions"}]}`` (``inspect_document``), what the planning page
        draws."""
        got = await self._read_request(request, creds, str(name), self._read_upload, name)
        if isinstance(got, JSONResponse):
            return got
        budget = self.config.plan_budget_s + self.config.answer_grace_s
        doc = await off_loop(self._executor, budget, f"the NDBG of {got.name} was not built "
                             f"within {budget:g} s", f"the NDBG of {got.name}",
                             inspect_document, got)
        return doc if isinstance(doc, JSONResponse) else JSONResponse(doc)

    @api.post("/export", summary="A plan as a robot program, checked by the arm's kinematics",
              openapi_extra=robot_program.EXPORT_OPENAPI)
    async def export(self, request: Request,
                     creds: HTTPAuthorizationCredentials | None = Security(bearer)):
        """The plan's robot program as an attachment (``rap.serve.robot_program``)."""
        read = await self._read_request(request, creds, "the export request", lambda body: (
            robot_program.parse_export_request(body, max_parts=self.config.max_parts,
                                               max_vertices=self.config.max_vertices)))
        if isinstance(read, JSONResponse):
            return read
        got = await off_loop(self._executor, self.config.plan_budget_s + self.config.answer_grace_s,
                             "the robot program took longer than its budget",
                             "the robot program", robot_program.program_file, read)
        return got if isinstance(got, JSONResponse) else Response(
            got.text, media_type=got.media_type, headers=got.headers)

    def __del__(self):
        try:
            self._maybe_flush(force=True)
        except Exception:
            pass


def build_app(config: ServeConfig):
    """The Serve application (``PlanningApp`` bound to ``config``)."""
    return PlanningApp.options(max_ongoing_requests=config.max_concurrent + 16,
                               graceful_shutdown_timeout_s=STOP_GRACE_S).bind(
        {**asdict(config)})
