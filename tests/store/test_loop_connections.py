"""The submit path's INSERT and the status read awaited on the event loop (``JobRepository.create_on_loop`` and
``get_brief_on_loop``, on ``LoopConnections``): the row is the one the thread's driver insert writes, the record
read is the one the thread's Core read returns, a taken idempotency key answers with the job that holds it,
a connection that broke is a 503-class error and is not handed out again, connections of a loop that ended are not
used by the next, and a black-holed link costs a request the same bounded seconds as on the engine's connections."""

from __future__ import annotations

import asyncio
import time
import uuid

import pytest
from sqlalchemy import select, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import OperationalError

from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.store import Database, JobRepository, engine
from plantsolve.store.loop_connections import LoopConnections
from plantsolve.store.repository import JOBS, LEFT_OUT_OF_BRIEF, JobRecord, StoredArtifact
from tests.support.black_hole import BlackHoleProxy

pytestmark = pytest.mark.integration


def _job(**extra) -> dict:
    return dict(id=uuid.uuid4(), kind="test-compute", status="queued", body_hash="0" * 64, solver_version="1",
                input={"values": [1.5, 2.5], "name": "Zone \u00e9 \u2192 \u6c34", "nested": {"null": None}}, **extra)


def _repo(db: Database) -> tuple[JobRepository, LoopConnections]:
    connections = LoopConnections(db.engine, wait=db.wait, statement=10.0)
    return JobRepository(db.sessions, db.writing, loop_connections=connections), connections


@pytest.fixture
def db(pg_url):
    database = Database(pg_url)
    database.migrate()
    try:
        yield database
    finally:
        database.dispose()


def test_the_loop_insert_writes_the_row_the_threads_insert_writes(db):
    repo, connections = _repo(db)
    assert repo.creates_on_loop
    mine, created = asyncio.run(repo.create_on_loop(_job()))
    theirs, _ = repo.create(_job())
    assert created
    with db.engine.connect() as connection:
        rows = {row.id: dict(row._mapping) for row in connection.execute(select(JOBS).where(JOBS.c.id.in_([mine.id, theirs.id])))}
        nulls = connection.execute(text("SELECT input_options IS NULL, result IS NULL, report IS NULL FROM jobs "
                                        "WHERE id = :id"), {"id": mine.id}).one()
    assert tuple(nulls) == (True, True, True)  # a column left out is SQL NULL, not JSON null
    moments = ("id", "created_at", "enqueued_at", "callback_next_at")
    assert {k: v for k, v in rows[mine.id].items() if k not in moments} == \
        {k: v for k, v in rows[theirs.id].items() if k not in moments}
    assert rows[mine.id]["created_at"] == mine.created_at and repo.get(mine.id).input == _job()["input"]
    connections.close()


def test_the_loop_read_returns_the_record_and_artifacts_the_threads_read_returns(db):
    repo, connections = _repo(db)
    job, _ = repo.create(_job(owner="alice", idempotency_key=f"alice:{uuid.uuid4()}", callback_url="https://x.test/h",
                              callback_state="pending", callback_attempts=0))
    attempt = repo.claim(job.id, lease_seconds=60, worker="w@host:1")
    artifacts = [StoredArtifact("b.txt", "text/plain", 3, "ab" * 32, f"{job.id}/b.txt"),
                 StoredArtifact("a.json", "application/json", 12, "cd" * 32, f"{job.id}/a.json")]
    assert repo.finish_success(job.id, attempt, result={"norm": 5.0}, report={"message": "ok", "warnings": [{"code": "x"}]},
                               artifacts=artifacts, run_seconds=0.25,
                               attempts=[{"attempt": 1, "worker": "w@host:1", "outcome": "succeeded"}])
    queued, _ = repo.create(_job())

    async def read():
        return [await repo.get_brief_on_loop(job_id) for job_id in (job.id, queued.id, uuid.uuid4())]

    (done, listed), (waiting, none_listed), (missing, nothing) = asyncio.run(read())
    for on_loop, job_id in ((done, job.id), (waiting, queued.id)):
        in_thread = repo.get(job_id, brief=True)
        assert not on_loop.complete and not hasattr(on_loop, "result")
        fields = [name for name in JobRecord.__slots__ if name not in LEFT_OUT_OF_BRIEF]
        assert {name: getattr(on_loop, name) for name in fields} == {name: getattr(in_thread, name) for name in fields}
    assert done.status == "succeeded" and done.report["warnings"] == [{"code": "x"}] and done.run_seconds == 0.25
    assert listed == sorted(artifacts, key=lambda a: a.name) and none_listed == []
    assert [(a.name, a.media_type, a.size, a.sha256) for a in repo.artifacts(job.id)] == \
        [(a.name, a.media_type, a.size, a.sha256) for a in listed]
    assert missing is None and nothing == []
    connections.close()


def test_a_taken_key_answers_with_the_job_that_holds_it_and_connections_are_reused(db):
    repo, connections = _repo(db)
    key = f"k-{uuid.uuid4()}"

    async def submit_twice():
        first = await repo.create_on_loop(_job(idempotency_key=key))
        again = await repo.create_on_loop(_job(idempotency_key=key))
        for _ in range(5):
            await repo.create_on_loop(_job())
        return first, again, len(connections._idle)

    (first, created), (again, created_again), idle = asyncio.run(submit_twice())
    assert created and not created_again and again.id == first.id
    assert idle == 1  # one request at a time: one connection, used again and again
    with db.engine.connect() as connection:
        assert connection.execute(text("SELECT count(*) FROM jobs WHERE idempotency_key = :key"), {"key": key}).scalar() == 1
    connections.close()


def test_a_broken_connection_is_an_infrastructure_error_and_is_not_used_again(db, monkeypatch):
    monkeypatch.setattr(engine, "PING_IDLE_SECONDS", 3600.0)  # no ping on checkout: the insert meets the break
    repo, connections = _repo(db)

    async def run():
        await repo.create_on_loop(_job())
        (pooled, _), = connections._idle
        with db.engine.connect() as connection:
            assert connection.execute(text("SELECT pg_terminate_backend(:pid)"), {"pid": pooled.get_server_pid()}).scalar()
        with pytest.raises(OperationalError) as raised:  # the server's last word (57P01), or the closed socket
            await repo.create_on_loop(_job())
        assert is_infrastructure_failure(raised.value)
        assert connections._idle == []  # the broken one was dropped
        job, created = await repo.create_on_loop(_job())  # a new connection: no restart
        return job, created

    job, created = asyncio.run(run())
    assert created and repo.get(job.id) is not None
    connections.close()


def test_the_connections_of_a_loop_that_ended_are_not_used_by_the_next(db):
    """A test client runs each request on a loop of its own when no lifespan holds one open."""
    repo, connections = _repo(db)
    asyncio.run(repo.create_on_loop(_job()))
    (old, _), = connections._idle
    job, created = asyncio.run(repo.create_on_loop(_job()))
    (new, _), = connections._idle
    assert created and new is not old and old.is_closed()
    connections.close()
    assert new.is_closed()


WAIT, STATEMENT = 1.5, 4.0


def test_a_black_holed_link_costs_the_bounded_seconds_on_loop_connections(pg_url):
    """A connection in use (back a moment ago: no ping) waits statement + wait for an answer, then is closed; one
    idle longer is pinged and given up on after the wait, then a new one's connect after about the wait again."""
    url = make_url(pg_url)
    proxy = BlackHoleProxy((url.host, url.port or 5432))
    db = Database(url.set(host="127.0.0.1", port=proxy.port).render_as_string(hide_password=False), wait=WAIT,
                  statement=STATEMENT)
    db.migrate()
    connections = LoopConnections(db.engine, wait=WAIT, statement=STATEMENT)
    repo = JobRepository(db.sessions, db.writing, loop_connections=connections)

    async def timed_failure():
        started = time.monotonic()
        with pytest.raises(OperationalError) as raised:
            await repo.create_on_loop(_job())
        assert is_infrastructure_failure(raised.value)
        return time.monotonic() - started

    async def run():
        await repo.create_on_loop(_job())
        proxy.swallow()
        in_use = await timed_failure()
        proxy.forward()
        await repo.create_on_loop(_job())  # a new connection
        await asyncio.sleep(engine.PING_IDLE_SECONDS + 0.1)
        proxy.swallow()
        idle = await timed_failure()
        proxy.forward()
        job, created = await repo.create_on_loop(_job())  # answers again, no restart
        return in_use, idle, created

    try:
        in_use, idle, created = asyncio.run(run())
    finally:
        connections.close()
        db.dispose()
        proxy.close()
    assert STATEMENT + WAIT <= in_use < STATEMENT + WAIT + 1.0, in_use
    assert WAIT <= idle < 2 * WAIT + 1.5, idle
    assert created


def test_a_url_with_parameters_asyncpg_reads_otherwise_is_left_to_the_engines_connections(pg_url):
    """libpq parameters asyncpg would send to the server as settings (which the server refuses) keep the thread's
    path; those it reads as libpq does are taken."""
    from plantsolve.store.loop_connections import available

    url = make_url(pg_url)
    for query, expected in (({}, True), ({"application_name": "api", "sslmode": "disable"}, True),
                            ({"connect_timeout": "5"}, False), ({"options": "-c search_path=x"}, False)):
        db = Database(url.update_query_dict(query).render_as_string(hide_password=False))
        try:
            assert available(db.engine) is expected, query
        finally:
            db.dispose()
    db = Database(url.update_query_dict({"application_name": "api-loop", "sslmode": "disable"})
                  .render_as_string(hide_password=False))
    db.migrate()
    repo, connections = _repo(db)

    async def run():
        await repo.create_on_loop(_job())
        (connection, _), = connections._idle
        return await connection.fetchval("SHOW application_name")

    try:
        assert asyncio.run(run()) == "api-loop"
    finally:
        connections.close()
        db.dispose()
