"""A PostgreSQL that stops answering without closing anything (a black-holed link: through
tests/support/black_hole.py) costs a request seconds, not minutes, on the connections pooled before it as on new
ones: submits and ``/readyz`` answer 503 within ``DATABASE_STATEMENT_SECONDS + DATABASE_WAIT_SECONDS``, and the
service answers again once the link does, without a restart."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.engine import make_url
from sqlalchemy.exc import DBAPIError, OperationalError

from plantsolve.app.main import create_app
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.store.engine import PING_IDLE_SECONDS, Database
from tests.conftest import service_settings
from tests.support.black_hole import BlackHoleProxy

pytestmark = pytest.mark.integration

WAIT, STATEMENT = 1.5, 4.0  # DATABASE_WAIT_SECONDS, DATABASE_STATEMENT_SECONDS of these tests
BOUND = STATEMENT + WAIT + 1.0  # the longest a request may take to give up (1 s for the test's own slack)
SUBMIT = ("/v1/test-compute/jobs", {"values": [1.5, 2.5]})


@pytest.fixture
def proxy(pg_url):
    url = make_url(pg_url)
    proxy = BlackHoleProxy((url.host, url.port or 5432))
    proxy.url = url.set(host="127.0.0.1", port=proxy.port).render_as_string(hide_password=False)
    yield proxy
    proxy.close()


def _timed(call):
    started = time.monotonic()
    outcome = call()
    return outcome, time.monotonic() - started


def test_a_pooled_connection_gives_up_on_a_black_hole_after_the_round_trip_bound(proxy):
    """A connection in use (no ping: it came back to the pool a moment ago) waits at most statement + wait for an
    answer, then is closed; one idle for longer is pinged and given up on after the wait alone."""
    db = Database(proxy.url, wait=WAIT, statement=STATEMENT)
    try:
        with db.engine.connect() as connection:
            connection.exec_driver_sql("SELECT 1")
            proxy.swallow()
            started = time.monotonic()
            with pytest.raises(OperationalError, match="no answer from the database within 5.5 s"):
                connection.exec_driver_sql("SELECT 2")
            took = time.monotonic() - started
            assert STATEMENT + WAIT <= took < BOUND, took
            assert connection.invalidated  # SQLAlchemy saw a disconnect: the pool will not hand it out again
        proxy.forward()
        db.ping()  # a new connection: the link answers again
        time.sleep(PING_IDLE_SECONDS + 0.1)
        proxy.swallow()
        started = time.monotonic()
        with pytest.raises(OperationalError):
            db.ping()  # the idle connection's ping: WAIT; then a new connection's connect timeout: about WAIT again
        took = time.monotonic() - started
        assert WAIT <= took < 2 * WAIT + 1.5, took
    finally:
        db.dispose()


def test_submits_and_readiness_answer_503_in_seconds_through_a_black_hole_and_recover(proxy, tmp_path):
    settings = service_settings(tmp_path, database_url=proxy.url, database_wait_seconds=WAIT,
                                database_statement_seconds=STATEMENT)
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        for _ in range(3):  # connections pooled while the link works
            assert client.post(SUBMIT[0], json=SUBMIT[1]).status_code == 202
        assert client.get("/readyz").status_code == 200
        proxy.swallow()
        for request in (lambda: client.post(SUBMIT[0], json=SUBMIT[1]), lambda: client.get("/readyz"),
                        lambda: client.post(SUBMIT[0], json=SUBMIT[1])):
            response, took = _timed(request)
            assert response.status_code == 503 and took < BOUND, (response.status_code, took, response.text)
        assert "database" in client.get("/readyz").json()["checks"]

        proxy.forward()
        deadline = time.monotonic() + 3 * BOUND
        while client.get("/readyz").status_code != 200:  # no restart: the pool connects anew
            assert time.monotonic() < deadline, "the service did not answer again after the link came back"
            time.sleep(0.2)
        response, took = _timed(lambda: client.post(SUBMIT[0], json=SUBMIT[1]))
        assert response.status_code == 202 and took < WAIT, took


def test_a_session_left_inside_a_transaction_is_ended_by_the_server(pg_url):
    """The server's side of a dead link: a client gone mid-transaction would keep its row locks (every later write
    of those rows waits out its lock timeout); the server ends such a session after statement + wait."""
    wait, statement = 0.5, 1.0
    db = Database(pg_url, wait=wait, statement=statement)
    try:
        with db.engine.connect() as connection:
            connection.exec_driver_sql("SELECT 1")  # a transaction is open (SQLAlchemy begins on first use)
            time.sleep(statement + wait + 1.0)
            with pytest.raises(DBAPIError, match="idle-in-transaction") as ended:
                connection.exec_driver_sql("SELECT 2")
            assert is_infrastructure_failure(ended.value)  # a 503 to a request, another attempt to a job
    finally:
        db.dispose()
