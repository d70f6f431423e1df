"""The sweeper loop: runs the lease policy (:func:`plantsolve.jobs.leases.sweep_once`) every
``SWEEP_SECONDS`` in a daemon thread of every API and worker process."""

from __future__ import annotations

import logging
import threading
from typing import Callable

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.jobs.leases import Enqueue, Pending, sweep_once

log = logging.getLogger("plantsolve.sweeper")


class Sweeper:
    """Runs :func:`sweep_once` every ``sweep_seconds`` in a daemon thread."""

    def __init__(self, ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None,
                 after_pass: Callable[[], None] | None = None):
        self.ctx, self.enqueue, self.pending, self.after_pass = ctx, enqueue, pending, after_pass
        self._stop = threading.Event()
        self._failed = False
        self._thread = threading.Thread(target=self._loop, name="sweeper", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def _loop(self) -> None:
        while not self._stop.wait(self.ctx.settings.sweep_seconds):
            self.run_pass()

    def run_pass(self) -> bool:
        """One pass; a pass that follows a failed one (the database was away) extends the running leases
        first (see :func:`plantsolve.jobs.leases.sweep_once`). Returns whether the pass succeeded."""
        try:
            sweep_once(self.ctx, self.enqueue, self.pending, after_outage=self._failed)
            self._failed = False
            if self.after_pass is not None:
                self.after_pass()
            return True
        except Exception as error:
            self._failed = True
            log.warning("sweep failed (%s): the next pass extends running leases", type(error).__name__,
                        exc_info=not is_infrastructure_failure(error))
            return False
