"""A client of the planning service (``rap-farm serve``, ``rap.serve.http_app``) on urllib (no ray).

    doc, details = post_plan("http://127.0.0.1:8000", plan_body(path, "rap", seed=None), token=None)
    result = PlanResult.from_json(doc, **details)        # rap.plan.report.result

``plan_body`` sends the assembly file's own JSON with its numbers written exactly as read (decimal
text, never through binary floats), so the service plans exactly the geometry that
``load_assembly`` reads here; a file without a ``"name"`` is sent under its file stem, as the local
``plan`` names it. ``post_plan`` returns the answer's body (the ``plan --out`` document) and the
service's ``X-Plan-Details`` header (``eval_seconds`` and ``stats``, for the printed summary).
Errors are one line naming the parameter ``server`` (a command shows its flag instead):
``ParameterError`` (exit status 2) for a request the service refused (4xx, its ``error`` text), a
wrong URL or an unreachable service; ``ServiceError`` (3) for a failure inside it. No ray, no torch.
"""

from __future__ import annotations

import json
import urllib.error
import urllib.parse
import urllib.request
from decimal import Decimal
from pathlib import Path
from typing import Any

from rap.errors import InputError, ParameterError, RapError
from rap.serve.api import DETAILS_HEADER

__all__ = ["plan_body", "post_plan", "exact_json", "ServiceError"]


class ServiceError(RapError):
    """The service at ``server`` failed on a valid request (5xx) or answered something
    unreadable. Exit 3. The message names the parameter, ``server http://h:8000: the service
    failed (HTTP 500): ...``; a command passes its flag as ``name``."""

    exit_code = 3

    def __init__(self, server: str, reason: str, name: str = "server"):
        self.server, self.reason = server, reason
        super().__init__(f"{name} {server}: {reason}")


def exact_json(value: Any) -> str:
    """JSON text of decoded JSON whose numbers are ``int``/``Decimal`` (``Decimal`` written as its
    exact decimal text)."""
    if isinstance(value, dict):
        return "{" + ",".join(f"{json.dumps(str(k))}:{exact_json(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(exact_json(v) for v in value) + "]"
    if isinstance(value, Decimal):
        if not value.is_finite():
            raise ValueError(f"non-finite number {value}")
        return str(value)
    return json.dumps(value)


def plan_body(assembly_path: str | Path, method: str, seed: int | None = None,
              options: dict | None = None, constraints=None, loaded=None,
              rollouts: bool = True, perturbed: bool = False) -> bytes:
    """The ``POST /plan`` body for an assembly file (already checked by ``load_assembly``) or a
    drawing (.dxf, .svg: imported with the default options, as ``load_assembly`` does, unless
    ``loaded``, the ``Assembly`` the caller already read from it, is given: a drawing is
    imported once a command);
    ``options``: the method's planner options (``rap.serve.api.PLANNER_OPTIONS``), those not None;
    ``constraints``: the cell's ``rap.plan.cell.constraints.CellConstraints`` (sent when active);
    ``rollouts``: False asks the service not to measure the plan by rollouts; ``perturbed``:
    True asks for the perturbed candidate (``perturbed_candidate``)."""
    path = Path(assembly_path)
    if path.suffix.lower() in (".dxf", ".svg"):  # a drawing: sent as the assembly it imports to
        from rap.io import assembly_to_json, load_assembly

        data = assembly_to_json(loaded if loaded is not None else load_assembly(path))
    else:
        try:
            data = json.loads(path.read_text(encoding="utf-8"), parse_float=Decimal, parse_int=int)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read ({exc})") from None
    if isinstance(data, dict) and "name" not in data:
        data = {"name": path.stem, **data}
    body = {"assembly": data, "method": method}
    if seed is not None:
        body["seed"] = int(seed)
    options = {k: v for k, v in (options or {}).items() if v is not None}
    if options:
        body["options"] = options
    if constraints is not None and constraints.active:
        body["constraints"] = constraints.to_json()
    if not rollouts:
        body["rollouts"] = False
    if perturbed:
        body["perturbed_candidate"] = True
    return exact_json(body).encode("utf-8")


def _error_text(raw: bytes) -> str:
    try:
        doc = json.loads(raw)
        if isinstance(doc, dict) and isinstance(doc.get("error"), str):
            return doc["error"]
    except ValueError:
        pass
    text = raw.decode("utf-8", "replace").strip().splitlines()
    return text[0][:200] if text else "(empty answer)"


def post_plan(server: str, body: bytes, *, token: str | None = None,
              timeout_s: float = 600.0) -> tuple[dict, dict]:
    """POST ``body`` to ``server``/plan; (plan document, details). See module doc for errors."""
    parsed = urllib.parse.urlsplit(server)
    if parsed.scheme not in ("http", "https") or not parsed.netloc:
        raise ParameterError("server", server, "expected http://HOST:PORT or https://HOST:PORT",
                             quote=False)
    url = server.rstrip("/") + "/plan"
    headers = {"Content-Type": "application/json", "Accept": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(url, data=body, headers=headers, method="POST")
    try:
        with urllib.request.urlopen(req, timeout=timeout_s) as resp:
            raw = resp.read()
            details_text = resp.headers.get(DETAILS_HEADER)
    except urllib.error.HTTPError as exc:
        text = _error_text(exc.read())
        if exc.code == 401:
            raise ParameterError("server", server, f"not authorised ({text}); pass a token or "
                                 f"set RAP_FARM_TOKEN", quote=False) from None
        if 400 <= exc.code < 500:
            raise ParameterError("server", server, text, quote=False) from None
        raise ServiceError(server, f"the service failed (HTTP {exc.code}): {text}") from None
    except (urllib.error.URLError, OSError) as exc:
        why = getattr(exc, "reason", None) or exc
        raise ParameterError("server", server, f"cannot reach the planning service ({why})",
                             quote=False) from None
    try:
        doc = json.loads(raw)
        details = json.loads(details_text) if details_text else {}
    except ValueError:
        raise ServiceError(server, "the answer is not JSON") from None
    if not isinstance(doc, dict) or not isinstance(details, dict):
        raise ServiceError(server, "the answer is not a plan document")
    return doc, {"eval_seconds": float(details.get("eval_seconds", 0.0)),
                 "stats": dict(details.get("stats") or {})}
