"""A SQLite file on a full disk takes the write lock (the sweeper's check that the database takes a write passes) but
no heartbeat: each one meets SQLITE_FULL. A lease that lapsed meanwhile says nothing about its worker, so it is
extended once space returns, not swept. Before, the first pass after space came back took the running attempts back
(``bench/kill58.py`` ``disk-full``: both jobs lost their attempt and were solved twice). The disk is made "low" here by
a floor above its free space, as ``MIN_FREE_DISK_BYTES`` marks it for readiness."""

from __future__ import annotations

import time

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.lifecycle import RUNNING
from plantsolve.jobs.service import JobService
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings
from tests.jobs.test_runner import Recorder

LEASE = 0.6


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, lease_seconds=LEASE), migrate=True)
    yield context
    context.close()


def test_a_lease_that_lapsed_while_the_database_disk_was_low_is_extended_not_swept(ctx):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=LEASE, worker="w") == 1
    sweeper = Sweeper(ctx, lambda *a: None)
    ctx.store.min_free_disk_bytes = 2**62  # the SQLite file's disk is short of space from now
    assert not sweeper.run_pass()
    time.sleep(LEASE)  # no heartbeat got through meanwhile: the lease lapses
    assert not sweeper.run_pass()
    assert ctx.repo.get(job_id).status == RUNNING
    ctx.store.min_free_disk_bytes = 0  # space is back
    assert sweeper.run_pass()
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt) == (RUNNING, 1)
    assert ctx.repo.heartbeat(job_id, 1, lease_seconds=LEASE)  # the attempt still owns the job


def test_a_lease_that_lapsed_with_room_on_the_disk_is_still_swept(ctx):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=LEASE, worker="w") == 1
    sweeper = Sweeper(ctx, lambda *a: None)
    time.sleep(LEASE)
    assert sweeper.run_pass()
    job = ctx.repo.get(job_id)
    assert job.status != RUNNING and [a["outcome"] for a in job.attempts] == ["lost"]
