"""The embedded default: job processes that the API process starts and supervises.

The API process never computes: each job runs in a worker process of a ``pebble`` pool (spawned,
each with its own database connection), through the same :func:`run_job` as Celery workers, with
the same claim and fencing. The pool kills a worker at the kind's hard time limit (the job is then
failed with a report) and replaces dead workers; a worker that dies otherwise (out of memory, a
crash in native code) loses its lease and the sweeper re-queues the job. Readers never wait on a
solver: solvers write only through short fenced updates from their own processes.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
import time
import uuid
from concurrent.futures import CancelledError
from concurrent.futures import TimeoutError as FutureTimeout
from functools import partial

from pebble import ProcessExpired, ProcessPool

from plantsolve.jobs.context import ServiceContext, worker_name
from plantsolve.jobs.leases import resume
from plantsolve.jobs.runner import fail_killed_at_hard_limit, handed_back, run_job
from plantsolve.jobs.settings import JobSettings
from plantsolve.workers.logs import configure_logging
from plantsolve.workers.sweeper import Sweeper

log = logging.getLogger("plantsolve.processes")

# time for a solver to notice its soft limit, clean up and store a report before it is killed
HARD_LIMIT_GRACE = 5.0
# how long a stop waits for the job processes to end after the running jobs were handed back
STOP_SECONDS = 5.0

_worker_ctx: ServiceContext | None = None


PARENT_WATCH_SECONDS = 0.5


def _die_with_parent(parent: int) -> None:
    """End this job process as soon as its parent (the service that supervises it) is gone: a job
    process nobody supervises must not go on and write a result after the service was killed (the
    job's lease lapses and the next service re-queues it). An orphan is re-parented, so its parent
    pid changes; a daemon thread watches for that."""
    def watch() -> None:
        while True:
            time.sleep(PARENT_WATCH_SECONDS)
            if os.getppid() != parent:
                os._exit(70)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _start_worker(settings_json: str, parent: int) -> None:
    """Initializer of each worker process: its own settings object and database connections, and every kind's
    solver imported before the first job."""
    global _worker_ctx
    _die_with_parent(parent)
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")
    settings = JobSettings.model_validate_json(settings_json)
    # a solver must never slow down the API process that shares this machine with it
    os.nice(settings.job_niceness)
    configure_logging(settings.log_format, settings.log_level)
    _worker_ctx = ServiceContext.create(settings)
    _worker_ctx.preload()


def _run(job_id: str) -> str:
    """One delivery in a worker process; a re-queued job is handed back to the pool by the parent."""
    requeued: list[str] = []
    outcome = run_job(_worker_ctx, uuid.UUID(job_id), worker=worker_name("process"),
                      requeue=lambda jid, kind="": requeued.append(str(jid)), hard_limit_in_thread=False)
    return "requeued" if requeued else outcome


class ProcessDispatcher:
    """Job ids go to a supervised pool of worker processes (``EMBEDDED_WORKERS`` of them)."""

    in_process = True  # enqueue hands the id over in memory and returns at once

    def __init__(self, ctx: ServiceContext, workers: int | None = None):
        self.ctx = ctx
        self.size = workers or ctx.settings.embedded_workers
        # Jobs handed to the pool at once. The database is this dispatcher's queue: beyond the window a
        # job stays queued in its row and is pulled when a process frees up, so a backlog of thousands
        # costs the API process no memory (and no garbage-collector pauses) for pool tasks.
        self.window = max(4, 2 * self.size)
        self._pool: ProcessPool | None = None
        self._pending: set[uuid.UUID] = set()
        self._lock = threading.Lock()
        self._stopping = False
        # Whether a job may wait in its row beyond the window: set when an enqueue found the window full, cleared by a
        # refill that found no more. A finished job refills from the database only then: with nothing waiting, a
        # read per finished job would cost the API process more than the job's hand-over. The sweeper's pass
        # refills regardless (jobs queued by another process, or re-queued by the sweep itself).
        self._overflow = True
        self._sweeper = Sweeper(ctx, self.enqueue, self.pending, after_pass=partial(self._refill, always=True))

    def start(self) -> None:
        self._stopping = False
        settings = JobSettings.model_validate(self.ctx.settings.model_dump(include=set(JobSettings.model_fields)))
        self._pool = ProcessPool(max_workers=self.size, initializer=_start_worker,
                                 initargs=(settings.model_dump_json(), os.getpid()), context=multiprocessing.get_context("spawn"))
        resume(self.ctx, self.enqueue, self.pending)
        self._sweeper.start()

    def stop(self) -> None:
        """Drain: stop taking jobs, hand the running ones back to the queue (their attempt not counted:
        the service stopped, the job did not fail), then end the job processes (within ``STOP_SECONDS``).
        Jobs waiting for a process stay queued in the database; the next start resumes them all."""
        self._stopping = True
        self._sweeper.stop()
        with self._lock:
            running = list(self._pending)
        for job_id in running:
            try:
                handed_back(self.ctx, job_id)
            except Exception:  # the database is away: the lease lapses and the next start re-queues it
                log.warning("job %s: could not be handed back at stop", job_id, exc_info=True)
        if self._pool is not None:
            self._pool.stop()
            self._pool.join(timeout=STOP_SECONDS)
            self._pool = None

    def ping(self) -> None:
        if self._pool is None or not self._pool.active:
            raise RuntimeError("the job process pool is not running")

    def in_flight(self) -> int:
        """Jobs handed to the pool and not finished (at most ``window``)."""
        with self._lock:
            return len(self._pending)

    def pending(self) -> int:
        """Queued jobs this dispatcher holds: all of them, since it pulls them from the database."""
        return self.ctx.repo.count_queued()

    def enqueue(self, job_id: uuid.UUID, kind: str = "") -> None:
        if self._pool is None:
            raise RuntimeError("the job process pool is not running")
        with self._lock:
            if job_id in self._pending:
                return  # handed to the pool already
            if len(self._pending) >= self.window:
                self._overflow = True
                return  # waiting in its row until a process frees up (_refill)
            self._pending.add(job_id)
        spec = self.ctx.spec(kind) if kind else None
        if spec is None:
            job = self.ctx.repo.get(job_id)
            spec = self.ctx.spec(job.kind) if job is not None else None
        timeout = self.ctx.limits(spec)[1] + HARD_LIMIT_GRACE if spec is not None else None
        future = self._pool.schedule(_run, args=(str(job_id),), timeout=timeout)
        future.add_done_callback(partial(self._done, job_id))

    def _done(self, job_id: uuid.UUID, future) -> None:
        with self._lock:
            self._pending.discard(job_id)
        if self._stopping:
            return
        try:
            self._outcome(job_id, future)
        finally:
            self._refill()

    def _outcome(self, job_id: uuid.UUID, future) -> None:
        try:
            outcome = future.result()
        except FutureTimeout:  # the pool killed the worker at the hard limit
            if fail_killed_at_hard_limit(self.ctx, job_id):
                log.warning("job %s killed at its hard time limit", job_id)
            return
        except ProcessExpired as error:  # the worker died: its lease lapses, the sweeper re-queues
            log.error("job %s: worker process died (%s)", job_id, error)
            return
        except CancelledError:
            return
        except Exception:  # the pool must survive anything a job does
            log.exception("job %s: runner error", job_id)
            return
        if outcome == "requeued":
            try:
                self.enqueue(job_id)
            except RuntimeError:  # stopping: the next start (or the sweeper) picks it up
                pass

    def _refill(self, always: bool = False) -> None:
        """Hand the oldest queued jobs to the pool until the window is full again (after a finished job only when
        some may be waiting beyond the window: see ``_overflow``)."""
        with self._lock:
            free = self.window - len(self._pending)
            held = set(self._pending)
            if free <= 0 or self._stopping or not (always or self._overflow):
                return
            # cleared before the read: an enqueue that overflows after it sets it again (its row is committed before
            # the enqueue, so a read after the clear sees it either way)
            self._overflow = False
        try:
            # one more than fits: whether more wait than this refill takes
            waiting = [(j, kind) for j, kind in self.ctx.repo.queued_jobs(limit=free + len(held) + 1) if j not in held]
            if len(waiting) > free:
                self._overflow = True
            for job_id, kind in waiting[:free]:
                self.enqueue(job_id, kind)
        except Exception:  # the database is away (or the pool is stopping): the next pass refills
            self._overflow = True
            if not self._stopping:
                log.warning("refilling the job pool failed", exc_info=True)
