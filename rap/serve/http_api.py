"""The planning service's FastAPI application before its replica joins it: the page, the examples,
the documentation and the one-line JSON errors.

``api`` is the application that ``rap.serve.http_app.PlanningApp`` (the Ray Serve replica) is the
ingress of; the replica adds the endpoints that need its planning service (``/health``,
``/plan``, ``/import``, ``/inspect``, ``/export``). Here are the routes that need none, public as
the page is: ``GET /`` (the planning page, ``STATIC_DIR``), ``/static/`` (its files, and Swagger
UI's and ReDoc's from the fastapi-offline package: ``/docs`` and ``/redoc`` work offline),
``GET /examples`` and ``GET /examples/{name}`` (``rap.serve.examples``). Every error the
application answers, FastAPI's own included (a 404, a request that fails validation: 400), is
``error(status, message)``: ``{"error": "<one line>"}`` of at most 500 characters.
``inspect_document(assembly)`` is what ``POST /inspect`` answers.

Cost: importing it builds the FastAPI application (no ray, no planning service); the examples are
read from the package's files on each request, on a thread (sync endpoints);
``inspect_document`` builds the assembly's NDBG and counts the partitions of each of its cells.
"""

# No "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time.

from pathlib import Path

from fastapi import Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from fastapi_offline import FastAPIOffline
from starlette.exceptions import HTTPException as StarletteHTTPException

from rap import __version__
from rap.assembly import Assembly, assembly_to_json
from rap.serve.examples import UnknownExample, example, example_list

__all__ = ["api", "error", "inspect_document", "STATIC_DIR"]


def error(status: int, message: str, headers: dict | None = None) -> JSONResponse:
    """The answer to a request that fails: ``status`` and ``{"error": message}`` on one line."""
    line = " ".join(str(message).split())[:500] or "error"
    return JSONResponse({"error": line}, status_code=status, headers=headers)


#: the planning page (index.html, app.js, app.css), served at / and /static/ without a token
STATIC_DIR = Path(__file__).parent / "static"

# FastAPIOffline: FastAPI whose /docs and /redoc load Swagger UI and ReDoc from files shipped in
# the fastapi-offline package (served at /static/swagger/), not from a CDN: they work offline
api = FastAPIOffline(
    title="rap-farm planning service",
    version=__version__,
    description="Robust assembly sequences of planar parts (RAP, simulator-only, optimal, random). "
                "POST an assembly to /plan; the answer is the document `rap-farm plan --out` "
                "writes. POST a drawing (DXF, SVG) or an assembly file to /import or /inspect. "
                "Errors are `{\"error\": \"one line\"}` with a 4xx/5xx status. The planning "
                "page is at /, the example assemblies shipped in the package at /examples.",
    static_url="/static/swagger",
    swagger_ui_parameters={"validatorUrl": None},  # no badge fetched from swagger.io
)
api.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")


@api.get("/", include_in_schema=False)
async def page():
    """The planning page (rap/serve/static): upload, NDBG circle, plan, storyboard."""
    return FileResponse(STATIC_DIR / "index.html")


# the examples are public, as the page is: the package's own data, no token (sync: read on a thread)
@api.get("/examples", summary="The example assemblies shipped in the package")
def list_examples():
    """``[{"name", "parts"}]`` sorted by name: what the page offers to try with one click."""
    return example_list()


@api.get("/examples/{name}", summary="A shipped example's assembly JSON")
def get_example(name: str):
    """The example's assembly JSON, as ``/import`` answers for its file; 404 for another name."""
    try:
        return JSONResponse(example(name))
    except UnknownExample as exc:
        return error(404, str(exc))


def inspect_document(assembly: Assembly) -> dict:
    """What ``POST /inspect`` answers: ``{"assembly": <assembly JSON>, "cells": [{"kind":
    "vertex"|"arc", "direction": [dx, dy], "partitions": n}, ...]}``, the NDBG's cells CCW from
    angle 0 (as ``rap-farm inspect --json``) with the number of partitions of the whole assembly
    each admits (what ``rap-farm show`` shades its circle by, capped at 100,000)."""
    from rap.geometry.ndbg import build_ndbg
    from rap.geometry.partitions import cell_partition_counts

    ndbg = build_ndbg(assembly)
    counts = cell_partition_counts(ndbg, frozenset(assembly.ids))
    return {"assembly": assembly_to_json(assembly),
            "cells": [{"kind": c.kind, "direction": [c.unit[0], c.unit[1]], "partitions": n}
                      for c, n in zip(ndbg.cells, counts)]}


@api.exception_handler(StarletteHTTPException)
async def _http_error(request: Request, exc: StarletteHTTPException):
    return error(exc.status_code, exc.detail if isinstance(exc.detail, str) else "error",
                 getattr(exc, "headers", None))


@api.exception_handler(RequestValidationError)
async def _validation_error(request: Request, exc: RequestValidationError):
    first = exc.errors()[0] if exc.errors() else {}
    return error(400, f"invalid request: {first.get('msg', 'validation failed')}")
