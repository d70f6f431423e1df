"""The embedded default: a small pool of job threads inside the API process."""

from __future__ import annotations

import logging
import queue
import threading
import uuid

from plantsolve.jobs.context import ServiceContext, worker_name
from plantsolve.jobs.holds import LOOK_SECONDS, DiskHold
from plantsolve.jobs.leases import resume
from plantsolve.jobs.runner import run_job
from plantsolve.workers.sweeper import Sweeper

log = logging.getLogger("plantsolve.embedded")


class EmbeddedDispatcher:
    """Job ids go on an in-memory queue; each pool thread runs :func:`run_job` on them."""

    in_process = True  # enqueue hands the id over in memory and returns at once

    def __init__(self, ctx: ServiceContext, workers: int | None = None):
        self.ctx = ctx
        self.size = workers or ctx.settings.embedded_workers
        self._queue: queue.Queue[uuid.UUID | None] = queue.Queue()
        self._pending: set[uuid.UUID] = set()
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._sweeper = Sweeper(ctx, self.enqueue, self.pending)
        self._disk = DiskHold(ctx)
        self._stopping = threading.Event()
        self.name = worker_name("embedded")

    def enqueue(self, job_id: uuid.UUID, kind: str = "") -> None:
        with self._lock:
            if job_id in self._pending:
                return
            self._pending.add(job_id)
        self._queue.put(job_id)

    def pending(self) -> int:
        with self._lock:
            return len(self._pending)

    def ping(self) -> None:
        if self._threads and not any(t.is_alive() for t in self._threads):
            raise RuntimeError("the embedded job pool has stopped")

    def start(self) -> None:
        self._stopping.clear()
        for index in range(self.size):
            thread = threading.Thread(target=self._work, name=f"job-pool-{index}", daemon=True)
            thread.start()
            self._threads.append(thread)
        resume(self.ctx, self.enqueue, self.pending)
        self._sweeper.start()

    def stop(self) -> None:
        self._stopping.set()
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
            # a job taken while the disk is below its floor waits, queued (see jobs.holds); a stop leaves it so
            while not self._stopping.is_set() and self._held():
                self._stopping.wait(LOOK_SECONDS)
            with self._lock:
                self._pending.discard(job_id)
            if self._stopping.is_set():
                return
            try:
                run_job(self.ctx, job_id, worker=self.name, requeue=self.enqueue)
            except Exception:  # the pool must survive anything a job does
                log.exception("job %s: runner error", job_id)

    def _held(self) -> bool:
        try:
            return self._disk.holds()
        except Exception:  # the pool's threads must outlive a look that fails: it holds, the next look decides
            log.exception("the disk hold could not be asked; holding")
            return True
