"""Getting a job id to a worker: the in-process pool (embedded default) or Celery (scaled).

Both only ever carry the job id; the database row holds everything else. The API calls
:meth:`Dispatcher.enqueue` only after the job row is committed.
"""

from __future__ import annotations

import logging
import queue
import threading
import uuid
from typing import Protocol

from workers import registry
from workers.context import ServiceContext, worker_name
from workers.runner import lost_worker_report, run_job

log = logging.getLogger("plantsolve.dispatch")

REQUEUE_QUEUED_AFTER = 600.0  # s: a queued job not picked up by then may have lost its message


class Dispatcher(Protocol):
    def enqueue(self, job_id: uuid.UUID, kind: str) -> None: ...

    def ping(self) -> None:
        """Raise if the queue cannot accept jobs."""

    def start(self) -> None: ...

    def stop(self) -> None: ...


def sweep_once(ctx: ServiceContext, dispatcher: Dispatcher) -> None:
    outcome = ctx.repo.sweep(requeue_queued_after=REQUEUE_QUEUED_AFTER, report_for_lost=lost_worker_report)
    for job_id in outcome.requeued:
        job = ctx.repo.get(job_id)
        if job is not None and job.status == "queued":
            dispatcher.enqueue(job_id, job.kind)
            ctx.repo.mark_enqueued(job_id)
    if outcome.requeued or outcome.failed:
        log.info("sweeper: re-queued %d, failed %d", len(outcome.requeued), len(outcome.failed))


class Sweeper:
    """Periodically re-queues jobs whose lease lapsed. Safe to run in many processes at
    once: each transition is a conditional update that only one of them wins."""

    def __init__(self, ctx: ServiceContext, dispatcher: Dispatcher):
        self.ctx, self.dispatcher = ctx, dispatcher
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="sweeper", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _loop(self) -> None:
        while not self._stop.wait(self.ctx.settings.sweep_seconds):
            try:
                sweep_once(self.ctx, self.dispatcher)
            except Exception:
                log.exception("sweep failed")


class EmbeddedDispatcher:
    """A small pool of threads inside the API process (the embedded default)."""

    def __init__(self, ctx: ServiceContext, workers: int | None = None):
        self.ctx = ctx
        self.size = workers or ctx.settings.embedded_workers
        self._queue: queue.Queue[uuid.UUID | None] = queue.Queue()
        self._pending: set[uuid.UUID] = set()
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._sweeper = Sweeper(ctx, self)
        self.name = worker_name("embedded")

    def enqueue(self, job_id: uuid.UUID, kind: str = "") -> None:
        with self._lock:
            if job_id in self._pending:
                return
            self._pending.add(job_id)
        self._queue.put(job_id)

    def ping(self) -> None:
        if self._threads and not any(t.is_alive() for t in self._threads):
            raise RuntimeError("the embedded job pool has stopped")

    def start(self) -> None:
        for index in range(self.size):
            thread = threading.Thread(target=self._work, name=f"job-pool-{index}", daemon=True)
            thread.start()
            self._threads.append(thread)
        # Jobs left queued (or running with a dead lease) by a previous process are resumed.
        sweep_once(self.ctx, self)
        for job_id in self.ctx.repo.queued_ids():
            self.enqueue(job_id)
        self._sweeper.start()

    def stop(self) -> None:
        self._sweeper.stop()
        for _ in self._threads:
            self._queue.put(None)
        for thread in self._threads:
            thread.join(timeout=5)
        self._threads.clear()

    def _work(self) -> None:
        while True:
            job_id = self._queue.get()
            if job_id is None:
                return
            with self._lock:
                self._pending.discard(job_id)
            try:
                run_job(self.ctx, job_id, worker=self.name, requeue=self.enqueue)
            except Exception:  # the pool must survive anything a job does
                log.exception("job %s: runner error", job_id)


class CeleryDispatcher:
    """Sends ``plantsolve.run_job(job_id)`` with the kind's time limits (scaled mode)."""

    def __init__(self, ctx: ServiceContext):
        from workers.celery_app import create_celery

        self.ctx = ctx
        self.celery = create_celery(ctx.settings)
        self._sweeper = Sweeper(ctx, self)

    def enqueue(self, job_id: uuid.UUID, kind: str) -> None:
        spec = registry.get(kind)
        limits = {}
        if spec is not None:
            limits = {"soft_time_limit": spec.soft_time_limit, "time_limit": spec.time_limit}
        self.celery.send_task("plantsolve.run_job", args=[str(job_id)], **limits)

    def ping(self) -> None:
        with self.celery.connection_for_write() as connection:
            connection.ensure_connection(max_retries=1, timeout=2)

    def start(self) -> None:
        self._sweeper.start()

    def stop(self) -> None:
        self._sweeper.stop()


def make_dispatcher(ctx: ServiceContext) -> Dispatcher:
    return EmbeddedDispatcher(ctx) if ctx.settings.embedded else CeleryDispatcher(ctx)
