"""The submit path's INSERT on PostgreSQL goes through the driver (``DriverInsert``): the row it writes is the one
SQLAlchemy's compiled insert writes, a taken idempotency key answers with the job that holds it, and a connection
that broke under the write is a 503-class error (SQLAlchemy's, marked invalidated) after which the next submit
works without a restart."""

from __future__ import annotations

import uuid

import pytest
from sqlalchemy import select, text
from sqlalchemy.exc import OperationalError

from plantsolve.store import Database, JobRepository, engine
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.store.repository import INSERT_JOB, JOBS, new_job_row

pytestmark = pytest.mark.integration


def _job(**extra) -> dict:
    return dict(id=uuid.uuid4(), kind="test-compute", status="queued", body_hash="0" * 64, solver_version="1",
                input={"values": [1.5, 2.5], "name": "Zone \u00e9 \u2192 \u6c34", "nested": {"null": None}}, **extra)


@pytest.fixture
def admin(pg_url):
    db = Database(pg_url)
    try:
        yield db
    finally:
        db.dispose()


@pytest.fixture
def repo(pg_url):
    db = Database(pg_url)
    db.migrate()
    try:
        yield JobRepository(db.sessions, db.writing)
    finally:
        db.dispose()


def test_the_driver_insert_writes_the_row_sqlalchemys_insert_writes(repo):
    assert repo._insert is not None  # PostgreSQL: the driver path
    ours, created = repo.create(_job())
    assert created
    theirs = _job()
    with repo._engine.begin() as connection:  # SQLAlchemy's compiled insert, as before
        connection.execute(INSERT_JOB, {k: v for k, v in new_job_row(theirs).items() if v is not None})
    with repo._engine.connect() as connection:
        rows = {row.id: row._mapping for row in connection.execute(select(JOBS).where(JOBS.c.id.in_([ours.id, theirs["id"]])))}
        # a column left out is SQL NULL, not JSON null
        nulls = connection.execute(text("SELECT input_options IS NULL, result IS NULL, report IS NULL FROM jobs "
                                        "WHERE id = :id"), {"id": ours.id}).one()
    assert tuple(nulls) == (True, True, True)
    mine, other = dict(rows[ours.id]), dict(rows[theirs["id"]])
    moments = ("id", "created_at", "enqueued_at", "callback_next_at")
    assert {k: v for k, v in mine.items() if k not in moments} == {k: v for k, v in other.items() if k not in moments}
    assert mine["input"] == _job()["input"] and mine["status"] == "queued"
    assert mine["created_at"] == ours.created_at  # the record answered is the row stored
    assert repo.get(ours.id).input == ours.input


def test_a_taken_idempotency_key_answers_with_the_job_that_holds_it(repo, monkeypatch):
    """The unique index finds a taken key: a new key costs no read before the insert, a taken one one read after."""
    real, reads = repo.get_by_idempotency_key, []
    monkeypatch.setattr(repo, "get_by_idempotency_key", lambda key_read: reads.append(key_read) or real(key_read))
    key = f"k-{uuid.uuid4()}"
    first, created = repo.create(_job(idempotency_key=key))
    assert created and reads == []
    again, created_again = repo.create(_job(idempotency_key=key))
    assert not created_again and again.id == first.id and reads == [key]
    with repo._engine.connect() as connection:
        assert connection.execute(text("SELECT count(*) FROM jobs WHERE idempotency_key = :key"), {"key": key}).scalar() == 1

def test_a_connection_broken_under_the_insert_is_an_infrastructure_error_and_the_next_submit_works(repo, admin, monkeypatch):
    monkeypatch.setattr(engine, "PING_IDLE_SECONDS", 3600.0)  # no ping on checkout: the insert meets the break
    monkeypatch.setattr(engine, "spoke_while_idle", lambda fd: False)  # the server's farewell not arrived yet
    repo.create(_job())  # a pooled connection, back in the pool a moment ago (no ping before its next use)
    with repo._engine.connect() as connection:
        pid = connection.execute(text("SELECT pg_backend_pid()")).scalar()
    with admin.engine.connect() as connection:
        assert connection.execute(text("SELECT pg_terminate_backend(:pid)"), {"pid": pid}).scalar()
    with pytest.raises(OperationalError) as raised:
        repo.create(_job())
    assert raised.value.connection_invalidated and is_infrastructure_failure(raised.value)
    job, created = repo.create(_job())  # a new connection: no restart
    assert created and repo.get(job.id) is not None
