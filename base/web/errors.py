"""The one place where errors become HTTP responses: RFC 9457 problem+json.

Our own BurnedgeError subclasses carry their status; Litestar's own exceptions
(bad JSON, wrong types, unknown fields, unknown routes) are reshaped to the same
form; anything unexpected is logged and answered 500 without internals.
"""

from __future__ import annotations

import logging
import re
from http import HTTPStatus

from litestar import Request, Response
from litestar.exceptions import HTTPException, ValidationException
from litestar.response import Redirect

from base.web.pages.rendering import error_page
from base.web.pages.session import is_page_path
from schemas.capture import TUS_VERSION
from schemas.errors import BurnedgeError, PasswordChangeRequired, TooManyAttempts, TusVersionUnsupported
from schemas.problem import FieldProblem, Problem

log = logging.getLogger("burnedge.gateway")
PROBLEM_JSON = "application/problem+json"
TUS_PATH = "/api/v1/uploads"
_TYPE_BASE = "https://burnedge.invalid/problems/"


def _respond(problem: Problem, headers: dict[str, str] | None = None, request: Request | None = None) -> Response:
    if request is not None and is_page_path(request.url.path):
        # A browser page: the same problem as HTML (a sign-in redirect for 401).
        return error_page(request, problem.status, problem.title, problem.detail)
    return Response(content=problem, status_code=problem.status, media_type=PROBLEM_JSON, headers=headers)


def burnedge_error(request: Request, exc: BurnedgeError) -> Response:
    headers = {}
    if isinstance(exc, TooManyAttempts):
        headers["Retry-After"] = str(exc.retry_after_s)
    if exc.status == 401:
        headers["WWW-Authenticate"] = 'Bearer realm="burnedge"'
    if request.url.path.startswith(TUS_PATH):
        # tus clients expect the protocol headers on every answer, errors included.
        headers["Tus-Resumable"] = TUS_VERSION
        if isinstance(exc, TusVersionUnsupported):
            headers["Tus-Version"] = TUS_VERSION
    if isinstance(exc, PasswordChangeRequired) and is_page_path(request.url.path):
        # A temporary password set by an administrator: the browser goes where it can be changed.
        return Redirect(path="/account/password", status_code=303)
    current = exc.current
    if current is not None and getattr(current, "meta", None) is not None:
        headers["ETag"] = f'"{current.meta.version}"'
    problem = Problem(
        type=_TYPE_BASE + exc.slug,
        title=exc.title,
        status=exc.status,
        detail=exc.detail,
        instance=request.url.path,
        errors=exc.errors,
        current=current,
    )
    return _respond(problem, headers, request)


def validation_error(request: Request, exc: ValidationException) -> Response:
    """Body or parameter failed to decode: wrong type, unknown field, out of range, bad JSON."""
    errors = [
        FieldProblem(field=_json_path(item), message=str(item.get("message", "")))
        for item in (exc.extra if isinstance(exc.extra, list) else [])
        if isinstance(item, dict)
    ]
    detail = "; ".join(f"{e.field}: {e.message}" for e in errors) or exc.detail
    problem = Problem(
        type=_TYPE_BASE + "validation",
        title="Request not valid",
        status=400,
        detail=f"nothing was stored: {detail}",
        instance=request.url.path,
        errors=errors,
    )
    return _respond(problem, request=request)


_UNKNOWN_FIELD = re.compile(r"unknown field `([^`]+)`")


def _json_path(item: dict) -> str:
    """Litestar reports "weight_kg", "entries[1].fraction" or "data" (the body); answer in JSON paths."""
    key = str(item.get("key") or "")
    path = "$" if key in ("", "data") else f"$.{key}"
    unknown = _UNKNOWN_FIELD.search(str(item.get("message", "")))
    return f"{path}.{unknown.group(1)}" if unknown else path


def http_error(request: Request, exc: HTTPException) -> Response:
    problem = Problem(
        type=_TYPE_BASE + f"http-{exc.status_code}",
        title=_title(exc.status_code),
        status=exc.status_code,
        detail=str(exc.detail),
        instance=request.url.path,
    )
    return _respond(problem, exc.headers, request)


def too_deep(request: Request, exc: RecursionError) -> Response:
    """JSON nested beyond what the decoder will follow (no schema nests deeper than a few levels): a bad body, not
    a fault, so one warning line and no traceback. Other recursion errors are the gateway's own."""
    if "deserializing" not in str(exc):
        return unexpected_error(request, exc)
    log.warning("refused a JSON body nested too deeply on %s %s", request.method, request.url.path)
    problem = Problem(
        type=_TYPE_BASE + "validation",
        title="Request not valid",
        status=400,
        detail="nothing was stored: the JSON body is nested too deeply (no burnedge message nests more than a few "
        "levels)",
        instance=request.url.path,
    )
    return _respond(problem, request=request)


def unexpected_error(request: Request, exc: Exception) -> Response:
    log.exception("unhandled error on %s %s", request.method, request.url.path)
    problem = Problem(
        type=_TYPE_BASE + "internal-error",
        title="Internal error",
        status=500,
        detail="the gateway hit an unexpected error; nothing partial was stored. The log has details.",
        instance=request.url.path,
    )
    return _respond(problem, request=request)


def _title(status: int) -> str:
    try:
        return HTTPStatus(status).phrase
    except ValueError:
        return "Error"


EXCEPTION_HANDLERS = {
    BurnedgeError: burnedge_error,
    ValidationException: validation_error,
    HTTPException: http_error,
    RecursionError: too_deep,
    Exception: unexpected_error,
}
