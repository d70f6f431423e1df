"""Comparing the lean path with the routes: a request with a query string goes to the routes (the lean path answers
only plain requests), and the routes refuse a query parameter they do not take. Built with :func:`routed_by`, the
app's routes also take the one parameter a test adds to route its requests."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from fastapi import Request

from plantsolve.app.jobs import endpoints


@contextmanager
def routed_by(name: str) -> Iterator[None]:
    """While an app is built inside this block, its routes take the query parameter ``name`` besides their own."""
    check = endpoints.known_query

    async def taking(request: Request) -> None:
        if set(request.query_params) != {name}:
            await check(request)

    built = endpoints.ROUTERS
    endpoints.known_query, endpoints.ROUTERS = taking, {}  # routers built with the check, not the process's
    try:
        yield
    finally:
        endpoints.known_query, endpoints.ROUTERS = check, built
