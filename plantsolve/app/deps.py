"""The dependencies routes declare, in one place: the job service of this app and the caller."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from plantsolve.app.auth import Principal, require_api_key
from plantsolve.jobs.service import JobService


def service_of(request: Request) -> JobService:
    """The job service of the app serving ``request`` (one per app, made in ``create_app``)."""
    return request.app.state.jobs


async def get_service(request: Request) -> JobService:  # async: no thread hop (see require_api_key)
    return service_of(request)


Service = Annotated[JobService, Depends(get_service)]
Caller = Annotated[Principal, Depends(require_api_key)]
