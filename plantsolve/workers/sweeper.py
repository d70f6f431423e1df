"""The sweeper loop: runs the lease policy (:func:`plantsolve.jobs.leases.sweep_once`) every
``SWEEP_SECONDS`` in a daemon thread of every API and worker process, and once per start the spool's sweep
(:func:`plantsolve.jobs.spool.sweep`: spooled results whose job ended while no process was left to remove them)."""

from __future__ import annotations

import logging
import threading
from typing import Callable

from plantsolve.jobs import spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.jobs.leases import Enqueue, Gone, Pending, sweep_once

log = logging.getLogger("plantsolve.sweeper")


# how long a stop waits for a pass under way to end (a pass is bounded by the database's own timeouts)
STOP_SECONDS = 5.0


class Sweeper:
    """Runs :func:`sweep_once` every ``sweep_seconds`` in a daemon thread; ``stop()`` then ``start()`` runs it again
    (its dispatcher is restartable)."""

    def __init__(self, ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None,
                 after_pass: Callable[[], None] | None = None, gone: Gone | None = None):
        self.ctx, self.enqueue, self.pending, self.after_pass, self.gone = ctx, enqueue, pending, after_pass, gone
        self._failed = False
        self._spool_swept = False
        self._lock = threading.Lock()
        self._stop: threading.Event | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the loop; a second start while it runs changes nothing. Each run has a thread and a stop event of
        its own: a pass of the previous run still under way (a stop waits only ``STOP_SECONDS``) sees its own event
        set and ends, never loops on beside the new one."""
        with self._lock:
            if self._stop is not None and not self._stop.is_set():
                return
            self._stop = threading.Event()
            self._spool_swept = False
            self._thread = threading.Thread(target=self._loop, args=(self._stop,), name="sweeper", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        with self._lock:
            stop, thread = self._stop, self._thread
            if stop is not None:
                stop.set()
        if thread is not None and thread is not threading.current_thread():
            thread.join(STOP_SECONDS)

    def _loop(self, stop: threading.Event) -> None:
        self.sweep_spool()
        while not stop.wait(self.ctx.settings.sweep_seconds):
            self.run_pass()
            self.sweep_spool()

    def sweep_spool(self) -> bool:
        """The spool's sweep, once per start: tried again after each pass until it has run (the database may be away
        at the start). Returns whether it has run."""
        if self._spool_swept:
            return True
        try:
            spool.sweep(self.ctx)
        except Exception as error:
            log.warning("the spool's sweep failed (%s): tried again after the next pass", type(error).__name__,
                        exc_info=not is_infrastructure_failure(error))
            return False
        self._spool_swept = True
        return True

    def run_pass(self) -> bool:
        """One pass; a pass that follows a failed one (the database was away) extends the running leases
        first (see :func:`plantsolve.jobs.leases.sweep_once`). A pass first checks that the database takes a write
        (as readiness does): while it takes none (a SQLite file whose write lock another process holds, a read-only
        standby) nobody's heartbeat is written either, though the pass's reads go on and may find nothing to write;
        such a pass fails, so that the leases that lapse meanwhile are extended, not swept; so does one that judged no
        lease (the database's disk is low). Returns whether the pass succeeded."""
        try:
            self.ctx.db.ping()
            judged = sweep_once(self.ctx, self.enqueue, self.pending, after_outage=self._failed, gone=self.gone)
            if not judged and not self._failed:
                log.warning("the database's disk is low: leases that lapse are extended once it has room, not swept")
            self._failed = not judged
            if self.after_pass is not None:
                self.after_pass()
            return judged
        except Exception as error:
            self._failed = True
            log.warning("sweep failed (%s): the next pass extends running leases", type(error).__name__,
                        exc_info=not is_infrastructure_failure(error))
            return False
