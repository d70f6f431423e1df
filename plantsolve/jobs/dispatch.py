"""Getting a job id to a worker: the protocol every transport implements (the embedded pool, its
thread variant, Celery). A message carries only the job id; the database row holds everything else.
The job service calls :meth:`Dispatcher.enqueue` only after the job row is committed."""

from __future__ import annotations

import uuid
from typing import Protocol


class NoWorkers(RuntimeError):
    """The queue takes jobs, but no worker has said it is alive lately (WORKER_ALIVE_SECONDS): nobody would run
    them."""


class Dispatcher(Protocol):
    # True when enqueue hands the id over in this process's memory and returns at once (no broker across the
    # network): an event loop may call it. Transports without it are called from a thread.
    in_process: bool = False
    # True when the jobs run in processes the service does not start (Celery workers): ``ping`` then raises
    # :class:`NoWorkers` when the queue answers but none of them is there, and readiness names ``workers``.
    workers_apart: bool = False

    def enqueue(self, job_id: uuid.UUID, kind: str) -> None: ...

    # A transport whose ``enqueues_on_loop`` is True also has ``async def enqueue_on_loop(job_id, kind, meanwhile)``:
    # the same hand-over awaited on the running event loop (no thread), calling ``meanwhile()`` (when given) while
    # the queue answers.

    def ping(self) -> None:
        """Raise if the queue cannot accept jobs (:class:`NoWorkers`: it can, but nobody would run them)."""

    def pending(self) -> int | None:
        """Messages waiting for a worker, or None when the queue cannot tell."""

    def start(self) -> None: ...

    def stop(self) -> None: ...
