"""Getting a job id to a worker: the in-process pool (embedded default) or Celery (scaled).

Both only ever carry the job id; the database row holds everything else. The API calls
:meth:`Dispatcher.enqueue` only after the job row is committed.
"""

from __future__ import annotations

import uuid
from typing import Protocol

from plantsolve.workers.celery_app import CeleryDispatcher
from plantsolve.workers.context import ServiceContext
from plantsolve.workers.embedded import EmbeddedDispatcher
from plantsolve.workers.processes import ProcessDispatcher


class Dispatcher(Protocol):
    def enqueue(self, job_id: uuid.UUID, kind: str) -> None: ...

    def ping(self) -> None:
        """Raise if the queue cannot accept jobs."""

    def pending(self) -> int | None:
        """Messages waiting for a worker, or None when the queue cannot tell."""

    def start(self) -> None: ...

    def stop(self) -> None: ...


def make_dispatcher(ctx: ServiceContext) -> Dispatcher:
    if not ctx.settings.embedded:
        return CeleryDispatcher(ctx)
    return ProcessDispatcher(ctx) if ctx.settings.embedded_mode == "process" else EmbeddedDispatcher(ctx)
