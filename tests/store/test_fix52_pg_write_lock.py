"""A PostgreSQL jobs table another session holds a lock on that blocks writes (a migration's CREATE INDEX without
CONCURRENTLY, in its open transaction) is an outage for the sweeper, as a locked SQLite file is: heartbeats wait and
fail while reads go on. The sweeper's check that the database takes a write asked only whether the server is
read-only, so the pass under the lock succeeded and the pass after it re-queued the running job whose heartbeats
had been refused. The check now takes the lock an UPDATE takes, bounded by the database wait."""

from __future__ import annotations

import time
import uuid
from contextlib import contextmanager

import psycopg
import pytest
from sqlalchemy.exc import OperationalError

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.lifecycle import RUNNING
from plantsolve.jobs.service import JobService
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings
from tests.jobs.test_runner import Recorder

LEASE = 0.6
WAIT = 0.3


@pytest.fixture
def ctx(tmp_path, pg_url):
    context = ServiceContext.create(service_settings(tmp_path, database_url=pg_url, lease_seconds=LEASE,
                                                     database_wait_seconds=WAIT), migrate=True)
    yield context
    context.close()


@contextmanager
def _hold(pg_url):
    """Another session, holding a SHARE lock on jobs (CREATE INDEX) while the context lasts."""
    connection = psycopg.connect(pg_url.replace("postgresql+psycopg://", "postgresql://"))
    try:
        connection.execute(f"CREATE INDEX fix52_{uuid.uuid4().hex[:8]} ON jobs (id)")
        yield
    finally:
        connection.rollback()
        connection.close()


def test_a_lease_that_lapsed_under_a_table_lock_is_extended_not_swept(ctx, pg_url):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=LEASE, worker="w") == 1
    sweeper = Sweeper(ctx, lambda *a: None)
    with _hold(pg_url):
        assert not sweeper.run_pass()  # nothing could be written
        with pytest.raises(OperationalError):  # the worker's heartbeats are refused meanwhile
            ctx.repo.heartbeat(job_id, 1, lease_seconds=LEASE)
        time.sleep(LEASE)  # and its lease lapses
    assert sweeper.run_pass()
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt) == (RUNNING, 1)
    assert ctx.repo.heartbeat(job_id, 1, lease_seconds=LEASE)  # the attempt still owns the job


def test_the_write_check_fails_within_the_database_wait_and_passes_beside_writers(ctx, pg_url):
    with _hold(pg_url):
        started = time.monotonic()
        with pytest.raises(OperationalError):
            ctx.db.ping()
        assert time.monotonic() - started < WAIT + 1.0
    writer = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    other = psycopg.connect(ctx.db.url.replace("postgresql+psycopg://", "postgresql://"))
    try:
        other.execute("UPDATE jobs SET attempt = attempt WHERE id = %s", (writer,))  # a write in an open transaction
        ctx.db.ping()  # does not wait on it
    finally:
        other.rollback()
        other.close()
