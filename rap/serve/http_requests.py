"""Taking an HTTP request without blocking the event loop: its token, its body within a limit, and
its work on a thread within a budget, every failure answered with one line.

The replica (``rap.serve.http_app.PlanningApp``) takes each request through these:

* ``authorised(token, creds)``: None when no token is set or the request's ``Authorization:
  Bearer`` matches it (compared in constant time); else the 401 answer. ``bearer`` is the
  endpoints' security scheme (it never refuses by itself: ``authorised`` does).
* ``read_body(request, limit)``: the body's bytes, or the 413 answer when it is over ``limit``
  bytes. A body up to ``DRAIN`` times the limit is read and dropped, so that a client still
  sending gets the 413 and not a reset connection; a declared length past that is refused unread.
* ``off_loop(executor, budget_s, late, what, fn, *args)``: ``fn(*args)`` on ``executor``'s threads,
  never on the event loop (``/health`` answers throughout): its value, or the answer to send
  instead: ``BadRequest``'s status, 503 with ``late`` past ``budget_s`` (the thread runs on to its
  end, its result dropped), 400 for an ``InputError``, 500 for another ``RapError``, and 500
  "``what`` failed: ..." for anything else (logged with its traceback; the replica keeps serving).

Answers are ``rap.serve.http_api.error``'s ``{"error": "<one line>"}``. Cost: a body is held in
memory once (at most ``limit`` bytes); the work's own cost, on a thread.
"""

# No "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time.

import asyncio
import hmac
import logging

from fastapi import Request
from fastapi.responses import JSONResponse
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from rap.errors import InputError, RapError
from rap.serve.api import BadRequest
from rap.serve.http_api import error

__all__ = ["authorised", "bearer", "off_loop", "read_body", "DRAIN"]

DRAIN = 8  # bodies up to this many times the limit are read (and dropped) before the 413
_log = logging.getLogger(__name__)

bearer = HTTPBearer(auto_error=False, description="Needed when the service was started with a "
                                                  "token (always beyond loopback).")


def authorised(token: str | None,
               creds: HTTPAuthorizationCredentials | None) -> JSONResponse | None:
    """None when the request may go on (module doc), else the 401 answer."""
    if not token:
        return None
    if creds is None or creds.scheme.lower() != "bearer" or not hmac.compare_digest(
            creds.credentials.encode(), token.encode()):
        return error(401, "missing or wrong bearer token (Authorization: Bearer <token>)",
                     {"WWW-Authenticate": "Bearer"})
    return None


async def read_body(request: Request, limit: int) -> bytes | JSONResponse:
    """The request's body, or the 413 answer when it is over ``limit`` bytes (module doc)."""
    length = request.headers.get("content-length")
    if length is not None and (not length.isdigit() or int(length) > DRAIN * limit):
        return error(413, f"request body over {limit} bytes")
    body, size = bytearray(), 0
    async for chunk in request.stream():  # a body a little too large is read and dropped,
        size += len(chunk)  # so that the client, still sending, gets the 413 and no reset
        if size <= limit:
            body += chunk
        elif size > DRAIN * limit:
            break
    if size > limit:
        return error(413, f"request body over {limit} bytes")
    return bytes(body)


async def off_loop(executor, budget_s: float, late: str, what: str, fn, *args):
    """``fn(*args)`` on ``executor``'s threads, never on the event loop: its value, or the
    answer to send instead (module doc)."""
    loop = asyncio.get_running_loop()
    try:
        return await asyncio.wait_for(loop.run_in_executor(executor, fn, *args),
                                      timeout=budget_s)
    except BadRequest as exc:
        return error(exc.status, exc.message)
    except asyncio.TimeoutError:
        return error(503, late)
    except RapError as exc:
        return error(400 if isinstance(exc, InputError) else 500, str(exc))
    except Exception as exc:  # never a traceback to the client, never a dead replica
        _log.exception("%s failed", what)
        return error(500, f"{what} failed: {type(exc).__name__}: {exc}")
