"""When queued jobs are held instead of started: the disk of the service (``ARTIFACT_DIR``, the SQLite file) is below
``MIN_FREE_DISK_BYTES``. A job started then could solve for minutes and find no room for its result (a full disk
fails a job at once: :func:`plantsolve.jobs.attempts.judge`), so no worker starts one until space returns (a pool's
dispatcher waits; a Celery task is retried after :func:`held_countdown`); the held jobs stay queued (nothing
submitted is lost, no attempt is counted) and say so in their progress message, which the job's view and summary
show. Submissions meanwhile are refused with a 503 naming disk space, as ``/readyz`` is 503
naming ``disk`` (:class:`~plantsolve.jobs.errors.DiskSpaceLow`)."""

from __future__ import annotations

import logging
import threading
import time

from plantsolve.jobs.context import ServiceContext
from plantsolve.store.disk import DiskLow

log = logging.getLogger("plantsolve.holds")

DISK_WAIT = "waiting: disk space low"
# how often a hold looks at the disk and marks jobs queued meanwhile (re-queued by the sweep, or by another process)
LOOK_SECONDS = 1.0
# how long a held job's Celery task first waits before it asks again (its message is sent anew with this countdown:
# the job keeps its place in the broker, no attempt is counted); each wait doubles, up to half the sweeper's
# ``requeue_queued_after``, so a long outage costs each held job a write and a publish every few seconds at most
HELD_TASK_COUNTDOWN_SECONDS = 2.0


def held_countdown(retries: int, requeue_queued_after: float) -> float:
    """Seconds a held job's task waits after ``retries`` waits before it: 2, 4, 8 … up to half of
    ``requeue_queued_after`` (so its message is marked sent again before the sweeper takes it for lost)."""
    cap = max(HELD_TASK_COUNTDOWN_SECONDS, requeue_queued_after / 2)
    return min(HELD_TASK_COUNTDOWN_SECONDS * 2 ** min(retries, 30), cap)


def disk_low(ctx: ServiceContext) -> str | None:
    """Why the disk is short of space (the folders and their free space), or None when it has room. A disk whose
    free space cannot be read (a stale network mount: ESTALE) has no known room: it holds jobs and refuses
    submissions as a full one does, as readiness says ``disk`` then too."""
    try:
        ctx.store.check_disk()
    except DiskLow as error:
        return str(error)
    except OSError as error:
        return f"the free space of the service's disk could not be read ({error})"
    return None


class DiskHold:
    """A dispatcher's hold on starting jobs while the disk is low: :meth:`holds` answers whether to start none now,
    looking at the disk at most every ``LOOK_SECONDS``; on holding it marks the queued jobs waiting, on letting go it
    marks them queued again."""

    def __init__(self, ctx: ServiceContext):
        self.ctx = ctx
        self.held = False
        self._marked = True  # whether jobs may be marked waiting (by this hold, or by one of an earlier start)
        self._looked = float("-inf")
        self._lock = threading.Lock()  # a pool's threads ask it each

    def holds(self) -> bool:
        with self._lock:
            return self._holds()

    def _holds(self) -> bool:
        now = time.monotonic()
        if now - self._looked < LOOK_SECONDS:
            return self.held
        self._looked = now
        why = disk_low(self.ctx)
        if why is not None and not self.held:
            log.error("holding queued jobs: %s", why)
        elif why is None and self.held:
            log.warning("disk space is back: queued jobs start again")
        self.held = why is not None
        if self.held or self._marked:
            try:  # while held, each look marks the jobs queued since; once, when the hold ends, they are unmarked
                if self.held:
                    self.ctx.repo.mark_queued(DISK_WAIT)
                else:
                    self.ctx.repo.mark_queued("queued", only=DISK_WAIT)
                self._marked = self.held
            except Exception as error:  # the database is away: the hold stands (or ends) all the same
                log.warning("queued jobs could not be marked %s (%s)", "waiting" if self.held else "queued",
                            type(error).__name__)
                self._marked = True  # the next look tries again
        return self.held
