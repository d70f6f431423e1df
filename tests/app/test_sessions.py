"""Dashboard logins: a random server-side session (the cookie never holds the key) that logging out
revokes and that expires; the login form needs its CSRF token; failed logins are limited per client
address (429 with Retry-After)."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.login import log_in, login_csrf

KEYS = dict(api_keys=["alice:key-a", "bob:key-b"], admin_keys=["ops:root"])


@pytest.fixture
def app(tmp_path):
    return create_app(service_settings(tmp_path, **KEYS), run_jobs=False)


@pytest.fixture
def client(app):
    with TestClient(app) as client:
        yield client


def _browser(app) -> TestClient:
    """Another browser (its own cookie jar) on the same service."""
    return TestClient(app)


def test_the_cookie_is_a_random_session_not_the_key(client):
    login = log_in(client, "key-a", follow_redirects=False)
    assert login.status_code == 303
    session = client.cookies["plantsolve_session"]
    assert "key-a" not in login.headers["set-cookie"] and "key-a" not in session
    assert len(session) >= 43  # 256 random bits
    assert client.get("/dashboard").status_code == 200
    assert client.get("/v1/jobs").status_code == 200  # the session reads as alice
    again = _browser(client.app)
    log_in(again, "key-a")
    assert again.cookies["plantsolve_session"] != session  # a fresh token per login
    # the database keeps only the token's hash: the raw token is nowhere in the table
    with client.app.state.ctx.db.engine.connect() as connection:
        rows = connection.exec_driver_sql("SELECT token_hash, key_hash FROM dashboard_sessions").all()
    assert len(rows) == 2 and all(session not in row and "key-a" not in row for row in rows)
    # the key itself as a cookie opens nothing
    stolen = _browser(client.app)
    stolen.cookies.set("plantsolve_session", "key-a")
    stolen.cookies.set("plantsolve_key", "key-a")
    assert stolen.get("/v1/jobs").status_code == 401


def test_logout_revokes_the_session_everywhere(client):
    log_in(client, "key-b")
    session = client.cookies["plantsolve_session"]
    copy = _browser(client.app)  # a copy of the cookie, as a thief would hold it
    copy.cookies.set("plantsolve_session", session)
    assert copy.get("/v1/jobs").status_code == 200
    assert client.post("/dashboard/logout", follow_redirects=False).status_code == 303
    assert copy.get("/v1/jobs").status_code == 401
    assert copy.get("/dashboard", follow_redirects=False).headers["location"] == "/dashboard/login"
    assert client.get("/v1/jobs").status_code == 401  # the cookie was dropped by the browser too


def test_a_session_expires(client):
    client.app.state.sessions.lifetime_seconds = 1.0
    login = log_in(client, "key-a", follow_redirects=False)
    assert "max-age=1" in login.headers["set-cookie"].lower()
    session = client.cookies["plantsolve_session"]
    assert client.get("/v1/jobs").status_code == 200
    time.sleep(1.2)
    kept = _browser(client.app)  # a browser that ignores Max-Age
    kept.cookies.set("plantsolve_session", session)
    assert kept.get("/v1/jobs").status_code == 401
    assert kept.get("/dashboard", follow_redirects=False).headers["location"] == "/dashboard/login"


def test_a_session_ends_with_its_key(tmp_path):
    settings = service_settings(tmp_path, **KEYS)
    with TestClient(create_app(settings, run_jobs=False)) as first:
        log_in(first, "key-a")
        session = first.cookies["plantsolve_session"]
    rotated = service_settings(tmp_path, api_keys=["alice:key-a2"], admin_keys=["ops:root"])
    with TestClient(create_app(rotated, run_jobs=False)) as second:  # same database, alice's key replaced
        second.cookies.set("plantsolve_session", session)
        assert second.get("/v1/jobs").status_code == 401


def test_login_needs_its_csrf_token(client):
    assert client.post("/dashboard/login", data={"key": "key-a"}).status_code == 403  # no token, no cookie
    token = login_csrf(client)
    assert client.post("/dashboard/login", data={"key": "key-a"}).status_code == 403  # cookie without the field
    wrong = client.post("/dashboard/login", data={"key": "key-a", "csrf": token[::-1]})
    assert wrong.status_code == 403 and wrong.headers["content-type"] == "application/problem+json"
    elsewhere = _browser(client.app)  # a page of another site knows no token that matches this browser's cookie
    assert elsewhere.post("/dashboard/login", data={"key": "key-a", "csrf": token}).status_code == 403
    cross = client.post("/dashboard/login", data={"key": "key-a", "csrf": token}, headers={"Sec-Fetch-Site": "cross-site"})
    assert cross.status_code == 403
    assert "plantsolve_session" not in client.cookies
    assert client.post("/dashboard/login", data={"key": "key-a", "csrf": token}, follow_redirects=False).status_code == 303


def test_failed_logins_are_limited_per_address(app):
    with TestClient(app, client=("203.0.113.9", 5000)) as attacker, TestClient(app, client=("198.51.100.4", 5000)) as user:
        app.state.sessions.window_seconds = 3.0
        csrf = login_csrf(attacker)
        for _ in range(10):
            assert attacker.post("/dashboard/login", data={"key": "guess", "csrf": csrf}).status_code == 401
        limited = attacker.post("/dashboard/login", data={"key": "key-a", "csrf": csrf})  # even the right key
        assert limited.status_code == 429 and 1 <= int(limited.headers["retry-after"]) <= 3
        assert "plantsolve_session" not in attacker.cookies
        assert log_in(user, "key-a", follow_redirects=False).status_code == 303  # another address is not held up
        time.sleep(int(limited.headers["retry-after"]) + 0.1)
        assert attacker.post("/dashboard/login", data={"key": "key-a", "csrf": csrf},
                             follow_redirects=False).status_code == 303


@pytest.mark.integration
def test_two_api_processes_share_sessions_and_the_login_limit_on_postgresql(tmp_path, pg_url):
    """Two API processes on one PostgreSQL database: a session opened through one is honoured and revoked
    through the other, and the failed logins of one address count against it in both."""
    settings = service_settings(tmp_path, database_url=pg_url, **KEYS)
    first, second = create_app(settings, run_jobs=False), create_app(settings, run_jobs=False)
    address = (f"192.0.2.{int(time.time() * 1000) % 250 + 1}", 5000)  # this run's own address on the shared database
    with TestClient(first, client=address) as a, TestClient(second, client=address) as b:
        log_in(a, "key-a")
        b.cookies.set("plantsolve_session", a.cookies["plantsolve_session"])
        assert b.get("/v1/jobs").status_code == 200
        assert b.post("/dashboard/logout", follow_redirects=False).status_code == 303
        assert a.get("/v1/jobs").status_code == 401
        csrf_a, csrf_b = login_csrf(a), login_csrf(b)
        for client, csrf in [(a, csrf_a), (b, csrf_b)] * 5:
            assert client.post("/dashboard/login", data={"key": "guess", "csrf": csrf}).status_code == 401
        assert a.post("/dashboard/login", data={"key": "key-a", "csrf": csrf_a}).status_code == 429
        assert b.post("/dashboard/login", data={"key": "key-a", "csrf": csrf_b}).status_code == 429


def test_a_session_lookup_during_a_database_outage_is_a_503(app, monkeypatch):
    from sqlalchemy.exc import OperationalError

    def away(*args, **kwargs):
        raise OperationalError("SELECT 1", {}, ConnectionRefusedError("connection refused"))

    with TestClient(app, raise_server_exceptions=False) as client:
        log_in(client, "key-a")
        csrf = login_csrf(client)
        monkeypatch.setattr(app.state.ctx.store.sessions, "key_of", away)
        monkeypatch.setattr(app.state.ctx.store.sessions, "failures_since", away)
        for response in (client.get("/v1/jobs", headers={"X-Request-ID": "3f1c0a52-5c1e-4a43-9d3b-0a5c7b2e9d10"}),
                         client.post("/dashboard/login", data={"key": "key-a", "csrf": csrf})):
            assert response.status_code == 503 and int(response.headers["retry-after"]) > 0, response.text[:200]
            assert response.headers["content-type"] == "application/problem+json"
            assert response.headers["x-request-id"]
