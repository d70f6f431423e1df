"""A job run by ``run_job`` in a thread of the test, returned once its attempt is running (claimed, solver started),
so a test can act on a running job: cancel it, kill its lease, watch it."""

from __future__ import annotations

import threading
import time
import uuid

from plantsolve.jobs.runner import run_job
from tests.support.dispatch import Recorder


def running_in_thread(ctx, job_id: uuid.UUID, worker: str = "w", wait: float = 10.0) -> tuple[threading.Thread, list]:
    """(thread, outcome): ``outcome`` receives run_job's return value when the thread ends."""
    outcome: list[str] = []
    thread = threading.Thread(target=lambda: outcome.append(run_job(ctx, job_id, worker=worker,
                                                                    requeue=Recorder().enqueue)))
    thread.start()
    deadline = time.monotonic() + wait
    while ctx.repo.get(job_id).status != "running":
        assert time.monotonic() < deadline, "the job did not start running"
        time.sleep(0.02)
    return thread, outcome
