"""A pooled PostgreSQL connection whose backend was ended meanwhile (``pg_terminate_backend``, a pooler or a failover
closing it) is not handed to a request: the request runs on a new connection instead of answering 503 while the
database is fine. The pooled connection was given back a moment ago, so no ping would have found it out."""

from __future__ import annotations

import asyncio
import time

import psycopg
import pytest
from sqlalchemy import text
from sqlalchemy.engine import make_url

from plantsolve.store import Database, engine
from plantsolve.store.loop_connections import LoopConnections

pytestmark = pytest.mark.integration


@pytest.fixture
def db(pg_url, monkeypatch):
    # every pooled connection counts as just given back: no ping before its use
    monkeypatch.setattr(engine, "PING_IDLE_SECONDS", 3600.0)
    database = Database(pg_url)
    try:
        yield database
    finally:
        database.dispose()


def _end_backends(pg_url: str) -> int:
    """End every other connection to the test's database and wait until they are gone; how many there were."""
    url = make_url(pg_url).set(drivername="postgresql")
    with psycopg.connect(url.render_as_string(hide_password=False), autocommit=True) as admin:
        ended = admin.execute("SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
                              "WHERE datname = current_database() AND pid <> pg_backend_pid()").fetchone()[0]
        until = time.monotonic() + 5
        while admin.execute("SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() "
                            "AND pid <> pg_backend_pid()").fetchone()[0]:
            assert time.monotonic() < until, "the backends did not end"
            time.sleep(0.02)
    time.sleep(0.05)  # the backend's farewell reaches this side's socket
    return ended


def test_an_engine_connection_ended_by_the_server_is_not_used(db, pg_url):
    with db.engine.connect() as connection:
        before = connection.execute(text("SELECT pg_backend_pid()")).scalar()
    assert _end_backends(pg_url) == 1
    with db.engine.connect() as connection:
        after = connection.execute(text("SELECT pg_backend_pid()")).scalar()
    assert after != before


@pytest.mark.parametrize("blocking", [False, True], ids=["ended-while-idle", "farewell-met-by-the-read"])
def test_a_loop_connection_ended_by_the_server_is_not_used_and_a_read_that_meets_its_farewell_is_asked_again(
        db, pg_url, blocking):
    """Ended while the loop is free, the closed connection is known and skipped; ended while the loop is blocked, the
    next read is sent before the farewell is read, meets it, and is asked once more on a new connection."""
    connections = LoopConnections(db.engine, wait=db.wait, statement=10.0)

    async def twice() -> tuple[int, int]:
        (first,) = await connections.fetch("SELECT pg_backend_pid() AS pid")
        if blocking:
            _end_backends(pg_url)
        else:
            await asyncio.to_thread(_end_backends, pg_url)
        (second,) = await connections.fetch("SELECT pg_backend_pid() AS pid")
        return first["pid"], second["pid"]

    try:
        before, after = asyncio.run(twice())
    finally:
        connections.close()
    assert after != before
