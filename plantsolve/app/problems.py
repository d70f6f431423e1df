"""Errors as classes with status codes, rendered as RFC 9457 ``application/problem+json``.

Every error the API returns goes through here, including FastAPI's own validation errors
and anything unexpected (a 500 still gets a problem document, never a stack trace).
"""

from __future__ import annotations

import logging
from typing import Any

from asgi_correlation_id import correlation_id
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect

from plantsolve.jobs.attempts import disk_full
from plantsolve.jobs.errors import (
    MAX_JSON_DEPTH,
    Conflict,
    DiskSpaceLow,
    NotFound,
    ProblemError,
    Unprocessable,
    UnsupportedMediaType,
    field_problem,
    is_infrastructure_failure,
    summary,
    user_path,
)
from plantsolve.schemas.jobs import Problem

log = logging.getLogger("plantsolve.api")

PROBLEM_JSON = "application/problem+json"
REQUEST_ID = "X-Request-ID"
RETRY_AFTER_SECONDS = 5


class Unauthorized(ProblemError):
    status, title, slug = 401, "Missing or invalid API key", "unauthorized"

    def __init__(self, detail: str):
        super().__init__(detail, headers={"WWW-Authenticate": 'Bearer realm="plantsolve"'})


class PayloadTooLarge(ProblemError):
    status, title, slug = 413, "Request body too large", "payload-too-large"


class RequestTimeout(ProblemError):
    status, title, slug = 408, "Request body too slow", "request-timeout"

    def __init__(self, detail: str):
        super().__init__(detail, headers={"Connection": "close"})


class ServiceUnavailable(ProblemError):
    status, title, slug = 503, "Service unavailable", "unavailable"


def unavailable(error: BaseException, path: str) -> ProblemError:
    """The 503 of an infrastructure failure (``is_infrastructure_failure``), logged as one line without a
    traceback: an outage answers many requests, and its cause is the same in each. A full disk (met while an upload
    was stored, say) is named as such, as readiness names ``disk``: waiting seconds will not help."""
    reason = (str(error).strip().splitlines() or [""])[0][:200]
    log.warning("503 on %s: %s%s", path, type(error).__name__, f": {reason}" if reason else "")
    if disk_full(error):
        return DiskSpaceLow("The service's disk is full, so this request could not be stored (nothing of it was "
                            "kept; the jobs already queued are not lost). Submit again once space is freed.")
    return ServiceUnavailable(
        "A service this request needs (the database, the queue or the file store) is unreachable; "
        "nothing was lost. Try again shortly.", headers={"Retry-After": str(RETRY_AFTER_SECONDS)})


def problem_response(error: ProblemError, request: Request | None = None) -> JSONResponse:
    problem = error.to_problem(instance=str(request.url.path) if request is not None else None)
    return JSONResponse(
        problem.model_dump(mode="json", exclude_none=True),
        status_code=error.status,
        media_type=PROBLEM_JSON,
        headers=error.headers,
    )


_STATUS_CLASSES = {cls.status: cls for cls in (Unauthorized, NotFound, Conflict, RequestTimeout, PayloadTooLarge,
                                                 UnsupportedMediaType, Unprocessable)}


def _place(error: dict[str, Any], request: Request) -> list[str | int]:
    """Where a routed request's validation error is: a JSON body's field by its path in the body as sent (as
    the submit routes name it: ``points/0/beta``, without the tags pydantic puts in for the member of a union);
    a query, path or header parameter as FastAPI names it (``query/limit``)."""
    loc = list(error["loc"])
    if loc[:1] == ["body"] and loc[1:] and error["type"] != "json_invalid":
        return user_path(loc[1:], _body_model(request))
    return loc  # the body as a whole (missing, not an object) is named 'body', as FastAPI names it


def _body_model(request: Request) -> type[BaseModel] | None:
    """The model a route validates its JSON body as (a kind operation's request), when it takes one whole."""
    body = getattr(request.scope.get("route"), "body_field", None)
    model = getattr(getattr(body, "field_info", None), "annotation", None)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def install(app: FastAPI) -> None:
    @app.exception_handler(ProblemError)
    async def _problem(request: Request, error: ProblemError):
        return problem_response(error, request)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, error: RequestValidationError):
        errors = [field_problem(_place(e, request), e["msg"], e["type"]) for e in error.errors()]
        return problem_response(Unprocessable(summary(errors), errors=errors), request)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, error: StarletteHTTPException):
        if error.status_code == 400 and str(error.detail) == "There was an error parsing the body":
            # FastAPI wraps whatever stopped it reading the body: our own bound (a stalled body's 408, an oversized
            # one's 413) answers as itself, a client that left needs no answer, the rest is a body that is no text
            if isinstance(error.__cause__, ProblemError):
                return problem_response(error.__cause__, request)
            if isinstance(error.__cause__, ClientDisconnect):
                raise error.__cause__
            return problem_response(Unprocessable("The body is not valid JSON text.", errors=[
                field_problem(["body"], "invalid JSON: not UTF-8 text", "json_invalid")]), request)
        cls = _STATUS_CLASSES.get(error.status_code)
        if cls is Unauthorized:
            problem = Unauthorized(str(error.detail))
        elif cls is not None:
            problem = cls(str(error.detail))
        else:
            problem = ProblemError(str(error.detail))
            problem.status, problem.title, problem.slug = error.status_code, str(error.detail), "http"
        response = problem_response(problem, request)
        for name, value in (getattr(error, "headers", None) or {}).items():  # Allow on 405, WWW-Authenticate ...
            response.headers.setdefault(name, value)
        return response

    @app.exception_handler(RecursionError)
    async def _too_deep(request: Request, error: RecursionError):
        return problem_response(Unprocessable(
            "The body is nested too deeply to be read.",
            errors=[field_problem([], f"JSON nested deeper than {MAX_JSON_DEPTH} levels", "json_too_deep")]), request)

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, error: Exception):
        # Starlette answers these outside every middleware: the request id is set here
        if is_infrastructure_failure(error):  # (the edge answers most of these before they get here)
            problem = unavailable(error, request.url.path)
        else:
            log.exception("unhandled error on %s", request.url.path)
            problem = ProblemError("An unexpected error occurred; it has been logged.")
        response = problem_response(problem, request)
        request_id = correlation_id.get() or request.headers.get(REQUEST_ID)
        if request_id:
            response.headers[REQUEST_ID] = request_id
        return response


PROBLEM_RESPONSES: dict[int | str, dict[str, Any]] = {
    status: {"model": Problem, "content": {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}}, "description": title}
    for status, title in (
        (400, "Malformed multipart body (too many fields or files)"),
        (401, "Missing or invalid API key (only when API_KEYS is set)"),
        (404, "No such job, kind or artifact"),
        (409, "The job is not in a state that allows this"),
        (413, "Request body above MAX_BODY_BYTES"),
        (415, "Unsupported content type or file type"),
        (422, "Invalid input: 'errors' names each bad field by its JSON path"),
        (500, "Unexpected error (logged; the document says no more)"),
        (503, "The database, the queue or the file store is unreachable, or the disk is short of space (type "
              "disk-space-low, as /readyz's 'disk'): nothing was lost, try again after Retry-After seconds"),
    )
}


def responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    return {status: PROBLEM_RESPONSES[status] for status in statuses}
