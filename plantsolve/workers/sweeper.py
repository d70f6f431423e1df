"""The sweeper: re-queues jobs whose lease lapsed (a killed worker) or whose queue message may
have been lost, and fails those past their attempt cap. It runs in every API and worker
process; each transition is a conditional update that only one of them wins."""

from __future__ import annotations

import logging
import threading
import uuid
from typing import Callable

from plantsolve.workers.context import ServiceContext
from plantsolve.workers.runner import lost_worker_report

log = logging.getLogger("plantsolve.sweeper")

REQUEUE_QUEUED_AFTER = 600.0  # s: a queued job not picked up by then may have lost its message

Enqueue = Callable[[uuid.UUID, str], None]


def sweep_once(ctx: ServiceContext, enqueue: Enqueue) -> None:
    outcome = ctx.repo.sweep(requeue_queued_after=REQUEUE_QUEUED_AFTER, report_for_lost=lost_worker_report)
    for job_id in outcome.requeued:
        job = ctx.repo.get(job_id)
        if job is not None and job.status == "queued":
            enqueue(job_id, job.kind)
            ctx.repo.mark_enqueued(job_id)
    if outcome.requeued or outcome.failed:
        log.info("sweeper: re-queued %d, failed %d", len(outcome.requeued), len(outcome.failed))


class Sweeper:
    """Runs :func:`sweep_once` every ``SWEEP_SECONDS`` in a daemon thread."""

    def __init__(self, ctx: ServiceContext, enqueue: Enqueue):
        self.ctx, self.enqueue = ctx, enqueue
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="sweeper", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _loop(self) -> None:
        while not self._stop.wait(self.ctx.settings.sweep_seconds):
            try:
                sweep_once(self.ctx, self.enqueue)
            except Exception:
                log.exception("sweep failed")
