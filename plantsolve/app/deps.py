"""The dependencies routes declare, in one place: the job service of this app, the caller, and the check that a
request names no query parameter its route does not take."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from plantsolve.app.auth import Principal, require_api_key
from plantsolve.jobs.errors import Unprocessable, field_problem
from plantsolve.jobs.service import JobService


def service_of(request: Request) -> JobService:
    """The job service of the app serving ``request`` (one per app, made in ``create_app``)."""
    return request.app.state.jobs


async def get_service(request: Request) -> JobService:  # async: no thread hop (see require_api_key)
    return service_of(request)


Service = Annotated[JobService, Depends(get_service)]
Caller = Annotated[Principal, Depends(require_api_key)]


async def known_query(request: Request) -> None:
    """Refuse (422 naming each) a query parameter the route does not take: a misspelt one (``?callbackurl=`` for
    ``callback_url``, ``?stauts=failed``) would otherwise be dropped without a word, and the job be submitted without
    its webhook, or the list be the whole list. The parameters a route takes are the ones its OpenAPI operation
    names (routes left out of the document are not checked)."""
    if not request.query_params:
        return
    taken = _query_names(request)
    if taken is None:
        return
    unknown = [name for name in dict.fromkeys(request.query_params.keys()) if name not in taken]
    if unknown:
        expected = ", ".join(sorted(taken)) or "none"
        raise Unprocessable(
            f"Unknown query parameter{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}; "
            f"this route takes: {expected}.",
            errors=[field_problem(["query", name], f"unknown query parameter (this route takes: {expected})",
                                  "extra_forbidden") for name in unknown])


def _query_names(request: Request) -> frozenset[str] | None:
    """The query parameters of the route serving ``request``, from the app's OpenAPI document (read once per
    route); None for a route the document leaves out."""
    route = request.scope.get("route")
    path = getattr(route, "path_format", None)
    key = (path, request.method.lower())
    cache = getattr(request.app.state, "query_names", None)
    if cache is None:
        cache = request.app.state.query_names = {}
    if key not in cache:
        operation = request.app.openapi().get("paths", {}).get(path, {}).get(key[1])
        cache[key] = None if operation is None else frozenset(
            parameter["name"] for parameter in operation.get("parameters", []) if parameter.get("in") == "query")
    return cache[key]
