"""A SQLite file whose write lock another process holds (a backup tool, an operator's ``sqlite3`` shell) is an outage
for the sweeper too: nobody's heartbeat is written meanwhile, so the lease that lapsed under the lock is extended once
the lock is gone, not swept. Before, a pass found nothing to write while the lock was held (reads go on under it), so
it counted as a success, and the pass after the lock took the running attempt back: an attempt counted, and the job
queued again, for a lock that was nobody's fault."""

from __future__ import annotations

import sqlite3
import time

import pytest
from sqlalchemy.exc import OperationalError

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.lifecycle import RUNNING
from plantsolve.jobs.service import JobService
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings
from tests.jobs.test_runner import Recorder

LEASE = 0.6


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, lease_seconds=LEASE, database_wait_seconds=0.3),
                                    migrate=True)
    yield context
    context.close()


def test_a_lease_that_lapsed_under_another_process_write_lock_is_extended_not_swept(ctx, tmp_path):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=LEASE, worker="w") == 1
    sweeper = Sweeper(ctx, lambda *a: None)
    holder = sqlite3.connect(tmp_path / "plantsolve.db", timeout=0, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        assert not sweeper.run_pass()  # the lease has not lapsed yet, but nothing could be written
        with pytest.raises(OperationalError):  # the worker's heartbeats are refused meanwhile
            ctx.repo.heartbeat(job_id, 1, lease_seconds=LEASE)
        time.sleep(LEASE)  # and its lease lapses
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    assert sweeper.run_pass()
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt) == (RUNNING, 1)
    assert ctx.repo.heartbeat(job_id, 1, lease_seconds=LEASE)  # the attempt still owns the job
