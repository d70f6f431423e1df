"""The lean path of the two hottest routes: ``POST /v1/<kind>/jobs`` with a JSON body and ``GET /v1/jobs/{id}``.

A client that submits and polls spends most of its requests here, and for such a small request the router's
route matching and dependency solving cost more than the database work. The edge middleware
(:mod:`plantsolve.app.edge`) has resolved the caller and applied the body limit; :meth:`LeanRoutes.match` takes
only the plain form of each request (no query string, a well-formed ``Idempotency-Key``, a canonical job id)
and leaves everything else, a malformed request too, to the routes in :mod:`plantsolve.app.jobs.endpoints`,
which stay the contract (the OpenAPI document) and give the 422 of a bad parameter. Both call the same service
methods and serialise the same view model, so the answer is the same byte for byte.
"""

from __future__ import annotations

import asyncio
import re
import uuid
from functools import partial
from typing import Awaitable, Callable, Iterable

from starlette.concurrency import run_in_threadpool
from starlette.requests import ClientDisconnect
from starlette.types import Receive, Scope, Send

from plantsolve.app.auth import Principal
from plantsolve.app.problems import Unauthorized
from plantsolve.jobs.service import JobService, Submitted

# the Idempotency-Key header's constraints in the route (1 to 255 printable ASCII characters, no leading space)
IDEMPOTENCY_KEY = re.compile(r"[\x21-\x7e][\x20-\x7e]{0,254}")
JOB_PATH = re.compile(r"/v1/jobs/([0-9a-fA-F]{8}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{12})")
JSON_HEADERS = [(b"content-type", b"application/json")]
# A JSON submission up to this size is read and checked on the event loop (tens of microseconds: less than the hop
# to a worker thread and back); a larger one in a thread, so that the loop serves other requests meanwhile (and so
# is a process's first submission of a kind, which imports the kind's checks).
LOOP_INTAKE_BYTES = 16 * 1024

def is_json(media_type: str) -> bool:
    """Whether a submission's media type (lower case, no parameters) is JSON: ``application/json`` or a ``+json``."""
    return media_type == "application/json" or media_type.endswith("+json")


LeanRoute = Callable[[Scope, Receive, Send, Principal], Awaitable[None]]


class LeanRoutes:
    """``inline_reads``: read a job's status on the event loop instead of in a worker thread. Right for a local
    SQLite database, where that read takes tens of microseconds (less than the hop to a thread and back) and never
    waits for a writer (WAL); a database across the network is waited for in a thread, so that the loop serves
    other requests meanwhile, or on the loop where the store can be awaited (PostgreSQL:
    :meth:`JobService.view_on_loop`). A small JSON submission is read and checked on the loop; its write is awaited on the
    loop where the store and the queue can be awaited (PostgreSQL and Redis: :meth:`JobService.store_on_loop`), goes
    to SQLite's group commit (awaited as a future), or else to a thread. A large body, an upload, and a process's
    first submission of a kind go to a thread whole."""

    def __init__(self, service: JobService, kinds: Iterable[str], *, inline_reads: bool = False):
        self.service = service
        self.inline_reads = inline_reads
        self.submit_paths = {f"/v1/{kind}/jobs": kind for kind in kinds}

    def match(self, scope: Scope) -> LeanRoute | None:
        """The lean handler of this request, or None when the app's routes answer it."""
        if scope["query_string"] or scope.get("root_path"):
            return None
        method, path = scope["method"], scope["path"]
        if method == "POST":
            kind = self.submit_paths.get(path)
            if kind is None:
                return None
            content_type, keys = None, []
            for name, value in scope["headers"]:
                name = name.lower()
                if name == b"content-type" and content_type is None:
                    content_type = value.decode("latin-1").split(";")[0].strip().lower()
                elif name == b"idempotency-key":
                    keys.append(value.decode("latin-1"))
            if not content_type or not is_json(content_type):
                return None  # an upload, or a content type the route refuses (415)
            if len(keys) > 1 or (keys and not IDEMPOTENCY_KEY.fullmatch(keys[0])):
                return None  # the route's header validation answers
            return partial(self.submit, kind, keys[0] if keys else None)
        if method == "GET" and (found := JOB_PATH.fullmatch(path)):
            return partial(self.get_job, uuid.UUID(found.group(1)))
        return None

    async def submit(self, kind: str, idempotency_key: str | None, scope: Scope, receive: Receive, send: Send,
                     caller: Principal) -> None:
        _require(caller)
        body = await _body(receive)
        if len(body) > LOOP_INTAKE_BYTES or not self.service.stores_inline(len(body)) \
                or not self.service.intake_loaded(kind):  # the first of a kind imports its checks: not on the loop
            submitted = await run_in_threadpool(self.service.with_view, self.service.submit_json, kind, body,
                                                idempotency_key, owner=caller.owner)
            await self._send_submitted(send, submitted)
            return
        new = self.service.take_json(kind, body, idempotency_key, owner=caller.owner)
        if self.service.stores_on_loop:  # PostgreSQL and Redis: both awaited here, no thread
            submitted = await self.service.store_on_loop(new)  # a new job's with its view
            if submitted.view is None:  # an existing one's (a repeated key) may read its artifacts: in a thread
                submitted.view = await run_in_threadpool(self.service.view, submitted.job)
            await self._send_submitted(send, submitted)
            return
        pending = self.service.store_later(new)
        if pending is None:  # a database that takes concurrent writers: the write (and view) in a thread
            submitted = await run_in_threadpool(self.service.with_view, self.service.store, new)
            await self._send_submitted(send, submitted)
            return
        # group commit (SQLite): answered after the commit that holds the row (written already when nothing else
        # was being written); the view's reads are local
        submitted = self.service.stored(new, *(pending.result() if pending.done() else
                                               await asyncio.wrap_future(pending)))
        submitted.view = self.service.view(submitted.job)
        await self._send_submitted(send, submitted)
        if submitted.created:  # after the answer: the client does not wait for the hand-over to the pool
            if self.service.dispatches_at_once:
                self.service.dispatch(submitted.job)
            else:
                await run_in_threadpool(self.service.dispatch, submitted.job)

    @staticmethod
    async def _send_submitted(send: Send, submitted: Submitted) -> None:
        location = f"/v1/jobs/{submitted.job.id}".encode()
        await _send_json(send, 202 if submitted.created else 200, submitted.view.model_dump_json().encode(),
                         [(b"location", location)])

    async def get_job(self, job_id: uuid.UUID, scope: Scope, receive: Receive, send: Send, caller: Principal) -> None:
        _require(caller)
        if self.service.reads_on_loop:  # PostgreSQL: awaited here, no thread
            await _send_json(send, 200, (await self.service.view_on_loop(job_id, caller.sees)).model_dump_json().encode())
            return
        call = partial(self._job_json, job_id, caller.sees)
        await _send_json(send, 200, call() if self.inline_reads else await run_in_threadpool(call))

    def _job_json(self, job_id: uuid.UUID, sees: str | None) -> bytes:
        return self.service.view(self.service.get(job_id, sees, brief=True)).model_dump_json().encode()


def _require(caller: Principal) -> None:
    if not caller.authenticated:  # as the routes' dependency (the middleware has refused unknown keys already)
        raise Unauthorized("Send 'Authorization: Bearer <key>'.")


async def _body(receive: Receive) -> bytes:
    chunks: list[bytes] = []
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            raise ClientDisconnect()
        chunks.append(message.get("body", b""))
        if not message.get("more_body", False):
            return b"".join(chunks)


async def _send_json(send: Send, status: int, body: bytes, headers: list[tuple[bytes, bytes]] = ()) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": [*headers, (b"content-length", str(len(body)).encode()), *JSON_HEADERS]})
    await send({"type": "http.response.body", "body": body})
