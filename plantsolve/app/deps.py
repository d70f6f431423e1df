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
    its webhook, or the list be the whole list. Only on routes that take parameters (on the others nothing can be
    misspelt), and never a name starting with ``_`` (cache busters: jQuery's ``?_=1700000000``)."""
    if not request.query_params:
        return
    taken = _query_names(request)
    if not taken:
        return
    unknown = [name for name in dict.fromkeys(request.query_params.keys())
               if name not in taken and not name.startswith("_")]
    if unknown:
        expected = ", ".join(sorted(taken))
        raise Unprocessable(
            f"Unknown query parameter{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}; "
            f"this route takes: {expected}.",
            errors=[field_problem(["query", name], f"unknown query parameter (this route takes: {expected})",
                                  "extra_forbidden") for name in unknown])


def _query_names(request: Request) -> frozenset[str] | None:
    """The query parameters the route serving ``request`` takes, its dependencies' included (read once per route);
    None when the request reached no route of FastAPI's."""
    route = request.scope.get("route")
    dependant = getattr(route, "dependant", None)
    if dependant is None:
        return None
    cache = getattr(request.app.state, "query_names", None)
    if cache is None:
        cache = request.app.state.query_names = {}
    key = (route.path, request.method)
    if key not in cache:
        names, todo = set(), [dependant]
        while todo:
            current = todo.pop()
            names |= {field.alias for field in current.query_params}
            todo += current.dependencies
        cache[key] = frozenset(names)
    return cache[key]
