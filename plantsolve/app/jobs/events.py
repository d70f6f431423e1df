"""Live progress as Server-Sent Events, read from the database.

``GET /v1/jobs/{id}/events``: an ``event: job`` with the job's view (the body of ``GET /v1/jobs/{id}``)
at once, another whenever its status or progress (fraction or message) changes, and after a
terminal status ``event: end`` with ``{"status": ...}``; then the stream closes.

``GET /v1/jobs/events``: an ``event: job`` for every job the caller may see whose status or
progress changes after the stream opened (filtered by ``kind`` and ``status``); it never ends.

Both poll the jobs' status columns every ``EVENTS_POLL_SECONDS`` instead of listening to the
process that runs the job: a job may run in a Celery worker on another machine, and the database
is the one place every mode writes progress to. A comment line every ``EVENTS_PING_SECONDS`` keeps
proxies from closing an idle stream; the stream stops when the client goes away. A database that goes away
while a stream is open pauses it (the pings go on) until it is back, instead of breaking it off mid-body, for at most
``EVENTS_OUTAGE_SECONDS``: then the stream sends ``event: error`` (a 503 problem, ``retry`` set to the reconnection
delay) and ends. One that is away when a stream is asked for is a 503 problem, as for every other request.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
import uuid
from datetime import datetime, timedelta, timezone
from typing import Any, AsyncIterator

from fastapi import APIRouter, Request
from sse_starlette import EventSourceResponse, ServerSentEvent
from starlette.concurrency import run_in_threadpool

from plantsolve.app.deps import Caller, Service
from plantsolve.app.problems import RETRY_AFTER_SECONDS, ServiceUnavailable, responses
from plantsolve.jobs.errors import NotFound, is_infrastructure_failure
from plantsolve.jobs.lifecycle import is_finished
from plantsolve.jobs.service import JobRecord, JobService, JobState
from plantsolve.schemas.jobs import JobStatus

EVENT_STREAM = "text/event-stream"

log = logging.getLogger("plantsolve.api")

# sent ahead of a new stream so that a client reconnects after this long (milliseconds)
RETRY_MS = 3000


def _stream_doc(text: str) -> dict[int | str, dict[str, Any]]:
    return {200: {"description": text, "content": {EVENT_STREAM: {"schema": {"type": "string"}}}}}


SEP = "\n"


def _job_event(view_json: str) -> ServerSentEvent:
    return ServerSentEvent(data=view_json, event="job", sep=SEP)


def _response(events: AsyncIterator[ServerSentEvent], request: Request) -> EventSourceResponse:
    return EventSourceResponse(events, ping=request.app.state.settings.events_ping_seconds, sep=SEP,
                               headers={"Cache-Control": "no-store"})


class _Outage:
    """A stream's database outages: a poll that found the database away is skipped (the stream pauses, its pings go
    on), said once in the log per outage, not at every poll; an outage longer than ``limit`` seconds ends the stream
    (:attr:`expired`, :meth:`ending`), so that no client waits on a stream that says nothing for as long as the
    database is away."""

    def __init__(self, what: str, limit: float, path: str, replayed: str):
        self.what, self.limit, self.path, self.replayed = what, limit, path, replayed
        self.since: float | None = None

    def met(self, error: Exception) -> ServerSentEvent | None:
        """A poll failed with ``error``: re-raised unless the database is away; the stream's last event
        (:meth:`ending`) once the outage has lasted ``limit`` seconds, else None (the stream pauses)."""
        if not is_infrastructure_failure(error):
            raise error
        if self.since is None:
            log.warning("event stream of %s paused: the database is away (%s)", self.what, type(error).__name__)
            self.since = time.monotonic()
        return self.ending() if self.expired else None

    def over(self) -> None:
        self.since = None

    @property
    def expired(self) -> bool:
        return self.since is not None and time.monotonic() - self.since >= self.limit

    def ending(self) -> ServerSentEvent:
        """The stream's last event: a 503 problem saying how long the database has been away, and when to reconnect
        (the ``retry`` field, and ``Retry-After`` seconds in the problem's details)."""
        log.warning("event stream of %s ended: the database has been away for %g s", self.what, self.limit)
        problem = ServiceUnavailable(
            f"The database has been unreachable for {self.limit:g} s (EVENTS_OUTAGE_SECONDS); this stream ends. "
            f"Reconnect after {RETRY_AFTER_SECONDS} s: {self.replayed}", extra={"retry_after": RETRY_AFTER_SECONDS})
        event = ServerSentEvent(data=json.dumps(problem.to_problem(instance=self.path).model_dump(
            mode="json", exclude_none=True)), event="error", sep=SEP)
        event.retry = RETRY_AFTER_SECONDS * 1000
        return event


async def job_event_stream(request: Request, service: JobService, job: JobRecord, sees: str | None) -> AsyncIterator[ServerSentEvent]:
    """The stream of ``job`` (read by the endpoint, so that a database away when it is asked for is a 503)."""
    settings = request.app.state.settings
    outage = _Outage(f"job {job.id}", settings.events_outage_seconds, request.url.path,
                     "the new stream starts with the job's view as it is then.")
    job_id = job.id
    first: ServerSentEvent | None = None
    while first is None:  # its view reads the artifacts too: the database may have gone since the endpoint's read
        try:
            first = _job_event((await run_in_threadpool(service.view, job)).model_dump_json())
        except Exception as error:
            if (ending := outage.met(error)) is not None:
                yield ending
                return
            await asyncio.sleep(settings.events_poll_seconds)
    outage.over()
    first.retry = RETRY_MS
    yield first
    seen = JobState.of(job).signature
    status = job.status
    while not is_finished(status):
        await asyncio.sleep(settings.events_poll_seconds)
        try:
            state = await run_in_threadpool(service.state, job_id)
            if state is None:  # deleted under us: nothing more will happen
                break
            if state.signature == seen:
                outage.over()
                continue
            job = await run_in_threadpool(service.get, job_id, sees, brief=True)
            view = await run_in_threadpool(service.view, job)
        except NotFound:  # deleted under us
            break
        except Exception as error:
            if (ending := outage.met(error)) is not None:
                yield ending
                return
            continue
        outage.over()
        seen = JobState.of(job).signature
        status = job.status
        yield _job_event(view.model_dump_json())
    yield ServerSentEvent(data=json.dumps({"status": status}), event="end", sep=SEP)


async def known_states(service: JobService, sees: str | None, kind: str | None) -> tuple[datetime, dict[uuid.UUID, tuple]]:
    """Where the stream of every job starts: the jobs it already knows (read by the endpoint, so that a database away
    when it is asked for is a 503) and the creation time from which it looks for new ones."""
    # a job created between two polls is caught by its creation time; a second of slack covers the
    # clocks of the processes that write created_at
    since = datetime.now(timezone.utc) - timedelta(seconds=1)
    states = await run_in_threadpool(lambda: service.states(since=since, owner=sees, kind=kind))
    return since, {state.id: state.signature for state in states}


async def jobs_event_stream(request: Request, service: JobService, sees: str | None, kind: str | None,
                            status: str | None, since: datetime,
                            known: dict[uuid.UUID, tuple]) -> AsyncIterator[ServerSentEvent]:
    settings = request.app.state.settings
    outage = _Outage("every job", settings.events_outage_seconds, request.url.path,
                     "the new stream sends the changes after it opens; those made meanwhile are in GET /v1/jobs.")
    opened = ServerSentEvent(comment="watching jobs", sep=SEP)
    opened.retry = RETRY_MS
    yield opened
    while True:
        await asyncio.sleep(settings.events_poll_seconds)
        now = datetime.now(timezone.utc)
        active = [job_id for job_id, signature in known.items() if not is_finished(signature[0])]
        # a poll the database failed is looked at again from the same creation time: no new job is missed, and a
        # change not sent (its signature not taken) is sent by the next poll
        missed = False
        try:
            states: list[JobState] = await run_in_threadpool(
                lambda: service.states(since=since, ids=active, owner=sees, kind=kind))
        except Exception as error:
            if (ending := outage.met(error)) is not None:
                yield ending
                return
            continue
        for state in states:
            if known.get(state.id) == state.signature:
                continue
            if status and state.status != status:
                known[state.id] = state.signature
                continue
            try:
                job = await run_in_threadpool(service.get, state.id, sees, brief=True)
                view = await run_in_threadpool(service.view, job)
            except NotFound:  # deleted under us
                known[state.id] = state.signature
                continue
            except Exception as error:
                missed = True
                if (ending := outage.met(error)) is not None:
                    yield ending
                    return
                continue
            known[state.id] = state.signature
            yield _job_event(view.model_dump_json())
        if not missed:
            since = now - timedelta(seconds=1)
            outage.over()
        # forget jobs that ended and left the creation window: nothing more happens to them
        current = {state.id for state in states}
        for job_id in [j for j, signature in known.items() if is_finished(signature[0]) and j not in current]:
            del known[job_id]


def add_event_routes(router: APIRouter) -> None:
    """Register the two streams on the /v1 router. Call before the ``/jobs/{job_id}`` routes:
    ``/jobs/events`` would otherwise be read as a job id."""

    @router.get(
        "/jobs/events",
        tags=["jobs"],
        operation_id="streamJobListEvents",
        summary="Live status and progress of every job (Server-Sent Events)",
        description=(
            "A `text/event-stream` of `event: job` (data: the job view, as `GET /v1/jobs/{id}`) for every job you "
            "may see whose status or progress changes after you connect; `kind` and `status` filter them (a job "
            "is sent when its new status matches). It ends only when the database stays unreachable for "
            "EVENTS_OUTAGE_SECONDS (30 s): then `event: error` (data: a 503 problem) with a `retry` delay; a comment "
            "line every ~15 s keeps it open."
        ),
        response_class=EventSourceResponse,
        responses={**_stream_doc("The event stream"), **responses(422)},
    )
    async def stream_job_list_events(request: Request, service: Service, caller: Caller, kind: str | None = None,
                                     status: JobStatus | None = None) -> EventSourceResponse:
        since, known = await known_states(service, caller.sees, kind)
        return _response(jobs_event_stream(request, service, caller.sees, kind, status, since, known), request)

    @router.get(
        "/jobs/{job_id}/events",
        tags=["jobs"],
        operation_id="streamJobEvents",
        summary="Live status and progress of a job (Server-Sent Events)",
        description=(
            "A `text/event-stream`: first `event: job` whose data is the job view (exactly `GET /v1/jobs/{id}`), "
            "then one whenever the status or progress (fraction or message) changes; after a terminal status "
            "(succeeded, failed, cancelled) `event: end` with data `{\"status\": \"<final>\"}`, and the stream "
            "closes. A database unreachable for EVENTS_OUTAGE_SECONDS (30 s) ends it too, with `event: error` (data: "
            "a 503 problem) and a `retry` delay. A comment line every ~15 s keeps it open."
        ),
        response_class=EventSourceResponse,
        responses={**_stream_doc("The event stream"), **responses(404, 422)},
    )
    async def stream_job_events(job_id: uuid.UUID, request: Request, service: Service, caller: Caller) -> EventSourceResponse:
        # an unknown or foreign job is a 404 problem before the stream starts
        job = await run_in_threadpool(service.get, job_id, caller.sees, brief=True)
        return _response(job_event_stream(request, service, job, caller.sees), request)
