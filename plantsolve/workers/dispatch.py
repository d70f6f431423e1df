"""Which transport carries job ids in this process: the supervised process pool (embedded
default), its thread variant (``EMBEDDED_MODE=thread``) or Celery (``BROKER_URL`` set)."""

from __future__ import annotations

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.dispatch import Dispatcher
from plantsolve.workers.embedded import EmbeddedDispatcher
from plantsolve.workers.processes import ProcessDispatcher


def make_dispatcher(ctx: ServiceContext) -> Dispatcher:
    if not ctx.settings.embedded:
        # imported here: Celery is the [scaled] extra, absent from the embedded default's install
        from plantsolve.workers.celery_app import CeleryDispatcher

        return CeleryDispatcher(ctx)
    return ProcessDispatcher(ctx) if ctx.settings.embedded_mode == "process" else EmbeddedDispatcher(ctx)
