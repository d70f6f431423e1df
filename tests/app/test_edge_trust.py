"""What the edge believes: X-Forwarded-For only from FORWARDED_ALLOW_IPS (the login limit counts the address it
trusts, through the very uvicorn configuration ``plantsolve serve`` uses), a login CSRF token only when the server
issued it, HSTS over TLS, no caching of private answers, no server banner, and an outage's 503s one log line each."""

from __future__ import annotations

import argparse
import logging
import threading
import time
import uuid
from contextlib import contextmanager

import httpx
import pytest
import uvicorn
from fastapi.testclient import TestClient
from sqlalchemy.exc import OperationalError

from plantsolve import cli
from plantsolve.app.auth import LoginTokens
from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.login import CSRF, log_in, login_csrf

KEYS = dict(api_keys=["alice:key-a"], admin_keys=["ops:root"])


@contextmanager
def served(app):
    """``app`` behind uvicorn configured as ``plantsolve serve`` configures it, on a free loopback port."""
    sock = cli.bind("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = uvicorn.Server(cli.server_config(app, argparse.Namespace(host="127.0.0.1", port=port,
                                                                      log_level="warning")))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert thread.is_alive() and time.monotonic() < deadline, "the server did not start"
        time.sleep(0.02)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}") as client:
            yield client
    finally:
        server.should_exit = True
        thread.join(timeout=15)
        sock.close()


def _bad_logins(client: httpx.Client, addresses: list[str], proto: str | None = None) -> list[int]:
    csrf = CSRF.search(client.get("/dashboard/login").text).group(1)
    codes = []
    for address in addresses:
        headers = {"X-Forwarded-For": address, **({"X-Forwarded-Proto": proto} if proto else {})}
        codes.append(client.post("/dashboard/login", data={"key": "guess", "csrf": csrf}, headers=headers).status_code)
    return codes


def test_a_new_forwarded_for_per_login_does_not_escape_the_limit(tmp_path):
    """uvicorn's own default believes X-Forwarded-For from loopback: 30 guesses with a new address each were all
    checked. Without FORWARDED_ALLOW_IPS the header is nobody's word: the connection's address is counted."""
    app = create_app(service_settings(tmp_path, **KEYS), run_jobs=False)
    with served(app) as client:
        codes = _bad_logins(client, [f"198.51.100.{i}" for i in range(1, 31)])
        assert codes == [401] * 10 + [429] * 20
        answer = client.get("/dashboard/login")
        assert "server" not in answer.headers  # no banner
        assert "strict-transport-security" not in answer.headers  # plain http
        faked = client.get("/dashboard/login", headers={"X-Forwarded-Proto": "https"})
        assert "strict-transport-security" not in faked.headers and "secure" not in faked.headers["set-cookie"].lower()


def test_behind_a_configured_proxy_the_forwarded_address_is_the_client(tmp_path):
    app = create_app(service_settings(tmp_path, forwarded_allow_ips=["127.0.0.1"], **KEYS), run_jobs=False)
    with served(app) as client:
        assert _bad_logins(client, [f"198.51.100.{i}" for i in range(1, 13)]) == [401] * 12  # 12 clients
        assert _bad_logins(client, ["203.0.113.7"] * 11) == [401] * 10 + [429]  # one client
        tls = client.get("/dashboard/login", headers={"X-Forwarded-Proto": "https"})
        assert tls.headers["strict-transport-security"] == "max-age=31536000"
        assert "secure" in tls.headers["set-cookie"].lower()


@pytest.fixture
def client(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, **KEYS), run_jobs=False)) as client:
        yield client


def test_a_login_token_the_server_did_not_issue_is_refused(client):
    """Double submit alone accepted any equal pair: a page of another site that can set the cookie (a sibling
    subdomain, say) chose both. Now the token must carry the server's signature and be fresh."""
    client.cookies.set("plantsolve_login", "z", path="/dashboard/login")
    assert client.post("/dashboard/login", data={"key": "key-a", "csrf": "z"}).status_code == 403
    foreign = LoginTokens(b"another service's secret").issue()  # well formed, signed with another key
    client.cookies.set("plantsolve_login", foreign, path="/dashboard/login")
    assert client.post("/dashboard/login", data={"key": "key-a", "csrf": foreign}).status_code == 403
    tokens = client.app.state.login_tokens
    issued = tokens.issue()
    stale = LoginTokens(tokens.secret, lifetime_seconds=-1)  # the same key, past its lifetime
    assert tokens.valid(issued) and not stale.valid(issued)
    tampered = issued[:-1] + ("0" if issued[-1] != "0" else "1")
    assert not tokens.valid(tampered) and not tokens.valid("") and not tokens.valid("1-2-3")
    assert "plantsolve_session" not in client.cookies
    assert log_in(client, "key-a", follow_redirects=False).status_code == 303


def test_the_login_secret_is_shared_by_processes_with_the_same_settings(tmp_path):
    settings = service_settings(tmp_path, **KEYS)
    first, second = create_app(settings, run_jobs=False), create_app(settings, run_jobs=False)
    other = create_app(service_settings(tmp_path, api_keys=["alice:key-a", "eve:key-e"]), run_jobs=False)
    with TestClient(first) as a, TestClient(second) as b, TestClient(other) as c:
        token = login_csrf(a)
        assert b.app.state.login_tokens.valid(token)
        assert not c.app.state.login_tokens.valid(token)  # another set of keys: another secret
        pinned = service_settings(tmp_path, login_secret="x" * 32, **KEYS)
        assert not create_app(pinned, run_jobs=False).state.login_tokens.valid(token)


def test_private_answers_are_not_stored_by_caches(client):
    alice = {"Authorization": "Bearer key-a"}
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=alice).json()
    for path, headers in (("/dashboard/login", {}), ("/dashboard", alice), (f"/dashboard/jobs/{job['id']}", alice),
                          ("/dashboard/submit/test-compute", alice), ("/v1/jobs", alice),
                          (f"/v1/jobs/{job['id']}", alice), ("/metrics", alice), ("/v1/jobs", {})):
        response = client.get(path, headers=headers)
        assert response.headers.get("cache-control") == "no-store", (path, response.status_code)
    assert "cache-control" not in client.get("/dashboard-static/dashboard.css").headers  # public assets may be
    assert "strict-transport-security" not in client.get("/dashboard/login").headers


def test_https_answers_carry_hsts(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, **KEYS), run_jobs=False),
                    base_url="https://testserver") as client:
        for response in (client.get("/dashboard/login"), client.get("/healthz"), client.get("/v1/jobs")):
            assert response.headers["strict-transport-security"] == "max-age=31536000"


def _away(*args, **kwargs):
    raise OperationalError("SELECT 1", {}, ConnectionRefusedError("connection refused"))


def test_an_outage_logs_one_line_per_503_and_no_traceback(tmp_path, monkeypatch, caplog):
    app = create_app(service_settings(tmp_path), run_jobs=False)
    # raise_server_exceptions: an error re-raised to the server (which then logs its traceback) fails the test
    with TestClient(app) as client:
        monkeypatch.setattr(app.state.jobs.ctx.repo, "get", _away)
        monkeypatch.setattr(app.state.jobs.ctx.repo, "count_by_status", _away)
        caplog.clear()
        paths = [f"/v1/jobs/{uuid.uuid4()}", "/dashboard", f"/v1/jobs/{uuid.uuid4()}/result"]
        for path in paths:
            response = client.get(path)
            assert response.status_code == 503 and int(response.headers["retry-after"]) > 0, path
            assert response.headers["x-request-id"] and response.headers["x-content-type-options"] == "nosniff"
        records = [r for r in caplog.records if r.levelno >= logging.WARNING and "API_KEYS is empty" not in r.message]
        assert [r.getMessage().split(":")[0] for r in records] == [f"503 on {path}" for path in paths]
        assert all(r.levelno == logging.WARNING and r.exc_info is None for r in records)
        assert "OperationalError" in records[0].getMessage()
