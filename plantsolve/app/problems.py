"""Errors as classes with status codes, rendered as RFC 9457 ``application/problem+json``.

Every error the API returns goes through here, including FastAPI's own validation errors
and anything unexpected (a 500 still gets a problem document, never a stack trace).
"""

from __future__ import annotations

import json
import logging
from typing import Any, Iterable, Sequence

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException

from plantsolve.schemas.jobs import Problem
from plantsolve.solvers.base import InputRejected

log = logging.getLogger("plantsolve.api")

PROBLEM_JSON = "application/problem+json"
TYPE_BASE = "https://plantsolve.dev/problems/"


def pointer(loc: Sequence[str | int]) -> str:
    return "".join("/" + str(part).replace("~", "~0").replace("/", "~1") for part in loc)


def field_problem(loc: Sequence[str | int], msg: str, type_: str = "value_error") -> dict[str, Any]:
    return {"loc": list(loc), "pointer": pointer(loc), "msg": msg, "type": type_}


class ProblemError(Exception):
    status: int = 500
    title: str = "Internal error"
    slug: str = "internal"

    def __init__(
        self,
        detail: str | None = None,
        *,
        errors: list[dict[str, Any]] | None = None,
        extra: dict[str, Any] | None = None,
        headers: dict[str, str] | None = None,
    ):
        self.detail = detail
        self.errors = errors
        self.extra = extra
        self.headers = headers or {}
        super().__init__(detail or self.title)

    def to_problem(self, instance: str | None = None) -> Problem:
        return Problem(
            type=TYPE_BASE + self.slug,
            title=self.title,
            status=self.status,
            detail=self.detail,
            instance=instance,
            errors=self.errors,
            extra=self.extra,
        )


class Unauthorized(ProblemError):
    status, title, slug = 401, "Missing or invalid API key", "unauthorized"

    def __init__(self, detail: str):
        super().__init__(detail, headers={"WWW-Authenticate": 'Bearer realm="plantsolve"'})


class NotFound(ProblemError):
    status, title, slug = 404, "Not found", "not-found"


class Conflict(ProblemError):
    status, title, slug = 409, "Conflict with the job's state", "conflict"


class PayloadTooLarge(ProblemError):
    status, title, slug = 413, "Request body too large", "payload-too-large"


class UnsupportedMediaType(ProblemError):
    status, title, slug = 415, "Unsupported media type", "unsupported-media-type"


class Unprocessable(ProblemError):
    status, title, slug = 422, "Invalid input", "invalid-input"


class ServiceUnavailable(ProblemError):
    status, title, slug = 503, "Service unavailable", "unavailable"


def from_validation_error(error: ValidationError, prefix: Sequence[str | int] = (), document: Any = None) -> Unprocessable:
    """422 naming each bad field; with the submitted ``document`` the locations are its JSON paths (the tags
    pydantic puts in them for a member of a union are left out)."""
    errors = [field_problem([*prefix, *json_path(document, e["loc"])], e["msg"], e["type"])
              for e in error.errors(include_url=False)]
    return Unprocessable(_summary(errors), errors=errors)


def json_path(document: Any, loc: Sequence[str | int]) -> list[str | int]:
    """``loc`` as a path into ``document``: a string step where the document has no such key and the path
    goes on (a union member's tag such as ``list[...]``) is dropped; a missing field, the last step, stays."""
    if document is None:
        return list(loc)
    path: list[str | int] = []
    node: Any = document
    for i, step in enumerate(loc):
        tag = isinstance(step, str) and (isinstance(node, list) or
                                         (isinstance(node, dict) and step not in node and i < len(loc) - 1))
        if tag:
            continue
        path.append(step)
        if isinstance(node, dict) and isinstance(step, str):
            node = node.get(step)
        elif isinstance(node, list) and isinstance(step, int) and -len(node) <= step < len(node):
            node = node[step]
        else:
            node = None
    return path


def from_input_rejected(error: InputRejected, prefix: Sequence[str | int] = ()) -> Unprocessable:
    errors = [field_problem([*prefix, *e.loc], e.msg, e.type) for e in error.errors]
    return Unprocessable(_summary(errors), errors=errors)


def _summary(errors: Iterable[dict[str, Any]]) -> str:
    parts = [f"{e['pointer'] or '(body)'}: {e['msg']}" for e in errors]
    text = "; ".join(parts[:5])
    return text + (f" (and {len(parts) - 5} more)" if len(parts) > 5 else "")


def problem_response(error: ProblemError, request: Request | None = None) -> JSONResponse:
    problem = error.to_problem(instance=str(request.url.path) if request is not None else None)
    return JSONResponse(
        problem.model_dump(mode="json", exclude_none=True),
        status_code=error.status,
        media_type=PROBLEM_JSON,
        headers=error.headers,
    )


_STATUS_CLASSES = {cls.status: cls for cls in (Unauthorized, NotFound, Conflict, PayloadTooLarge, UnsupportedMediaType, Unprocessable)}


MAX_JSON_DEPTH = 200


def loads_bounded(data: bytes | str, loc: Sequence[str | int], what: str) -> Any:
    """json.loads with a nesting limit: deeper documents (or unreadable ones) are a 422 naming ``loc``."""
    try:
        value = json.loads(data)
    except RecursionError:
        raise Unprocessable(f"{what} is nested too deeply to be read.",
                            errors=[field_problem(loc, f"JSON nested deeper than {MAX_JSON_DEPTH} levels",
                                                  "json_too_deep")]) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise Unprocessable(f"{what} is not valid JSON: {error}",
                            errors=[field_problem(loc, f"invalid JSON: {error}", "json_invalid")]) from None
    if _depth(value) > MAX_JSON_DEPTH:
        raise Unprocessable(f"{what} is nested too deeply to be read.",
                            errors=[field_problem(loc, f"JSON nested deeper than {MAX_JSON_DEPTH} levels",
                                                  "json_too_deep")])
    return value


def _depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value, without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item.values() if isinstance(v, (dict, list)))
        elif isinstance(item, list):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item if isinstance(v, (dict, list)))
    return deepest


def install(app: FastAPI) -> None:
    @app.exception_handler(ProblemError)
    async def _problem(request: Request, error: ProblemError):
        return problem_response(error, request)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, error: RequestValidationError):
        errors = [field_problem(e["loc"], e["msg"], e["type"]) for e in error.errors()]
        return problem_response(Unprocessable(_summary(errors), errors=errors), request)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, error: StarletteHTTPException):
        if error.status_code == 400 and str(error.detail) == "There was an error parsing the body":
            # FastAPI's answer to a JSON body that is not text: unreadable input like any other
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
        log.exception("unhandled error on %s", request.url.path)
        return problem_response(ProblemError("An unexpected error occurred; it has been logged."), request)


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
    )
}


def responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    return {status: PROBLEM_RESPONSES[status] for status in statuses}
