"""The job domain's errors, as classes: each names its status, title and problem type, and carries
the bad fields (``errors``, each with its JSON path and RFC 6901 pointer). The HTTP app renders them
as RFC 9457 problem documents (:mod:`plantsolve.app.problems`); the CLI prints them."""

from __future__ import annotations

import json
from typing import Any, Iterable, Sequence

from pydantic import ValidationError
from sqlalchemy import exc as sqlalchemy_exc

from plantsolve.schemas.jobs import Problem
from plantsolve.solvers.base import InputRejected

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


class NotFound(ProblemError):
    status, title, slug = 404, "Not found", "not-found"


class Conflict(ProblemError):
    status, title, slug = 409, "Conflict with the job's state", "conflict"


class UnsupportedMediaType(ProblemError):
    status, title, slug = 415, "Unsupported media type", "unsupported-media-type"


class Unprocessable(ProblemError):
    status, title, slug = 422, "Invalid input", "invalid-input"


def from_validation_error(error: ValidationError, prefix: Sequence[str | int] = (), document: Any = None) -> Unprocessable:
    """422 naming each bad field; with the submitted ``document`` the locations are its JSON paths (the tags
    pydantic puts in them for a member of a union are left out)."""
    errors = [field_problem([*prefix, *json_path(document, e["loc"])], e["msg"], e["type"])
              for e in error.errors(include_url=False)]
    return Unprocessable(summary(errors), errors=errors)


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
    return Unprocessable(summary(errors), errors=errors)


def summary(errors: Iterable[dict[str, Any]]) -> str:
    parts = [f"{e['pointer'] or '(body)'}: {e['msg']}" for e in errors]
    text = "; ".join(parts[:5])
    return text + (f" (and {len(parts) - 5} more)" if len(parts) > 5 else "")


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


INFRASTRUCTURE = (OSError, ConnectionError, TimeoutError, EOFError)
DATABASE_AWAY = (sqlalchemy_exc.OperationalError, sqlalchemy_exc.InterfaceError, sqlalchemy_exc.DisconnectionError,
                 sqlalchemy_exc.TimeoutError)


def is_infrastructure_failure(error: BaseException) -> bool:
    """A failure of the machine or its services (network, disk, database, broker) that another attempt
    (or request) may not meet; anything else a solver raises (numerical breakdown, a bug) repeats on the
    same input. The API answers these with 503 and ``Retry-After``, the runner retries them."""
    if isinstance(error, INFRASTRUCTURE):
        return True
    if isinstance(error, sqlalchemy_exc.SQLAlchemyError):  # not a constraint or a statement the code got wrong
        return isinstance(error, DATABASE_AWAY) or bool(getattr(error, "connection_invalidated", False))
    module = type(error).__module__ or ""
    return module.startswith(("psycopg", "redis", "kombu", "celery", "billiard", "amqp"))

