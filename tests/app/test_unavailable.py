"""Infrastructure trouble is a 503 with Retry-After (never a 500), and every answer, a 500 too, carries
the request id."""

from __future__ import annotations

import uuid

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.exc import OperationalError

from plantsolve.app.main import create_app

PROBLEM = "application/problem+json"


def _away(*args, **kwargs):
    raise OperationalError("SELECT 1", {}, ConnectionRefusedError("connection refused"))


@pytest.fixture
def app_and_client(settings):
    app = create_app(settings)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield app, client


def _unavailable(response):
    assert response.status_code == 503, response.text[:300]
    assert response.headers["content-type"] == PROBLEM
    assert int(response.headers["Retry-After"]) > 0
    assert response.json()["type"].endswith("/unavailable")
    assert "Traceback" not in response.text and "OperationalError" not in response.text
    return response


class _AwayEngine:
    def begin(self):
        _away()


def _database_away(app, monkeypatch, method: str) -> None:
    repo = app.state.jobs.ctx.repo
    if method == "writer":  # the group-commit thread's transaction fails: every submission in it is a 503
        monkeypatch.setattr(repo.writer, "engine", _AwayEngine())
    elif method == "create":  # a submission is stored one at a time, or through the group commit
        monkeypatch.setattr(repo, "create", _away)
        monkeypatch.setattr(repo, "create_later", _away)
    else:
        monkeypatch.setattr(repo, method, _away)


@pytest.mark.parametrize("method", ["get", "list", "create", "writer", "count_by_status"])
def test_reads_submits_and_the_dashboard_answer_503_while_the_database_is_away(app_and_client, monkeypatch, method):
    app, client = app_and_client
    _database_away(app, monkeypatch, method)
    request_id = str(uuid.uuid4())
    if method == "get":
        response = client.get(f"/v1/jobs/{uuid.uuid4()}", headers={"X-Request-ID": request_id})
    elif method == "list":
        response = client.get("/v1/jobs", headers={"X-Request-ID": request_id})
    elif method in ("create", "writer"):
        response = client.post("/v1/test-compute/jobs", json={"values": [1]}, headers={"X-Request-ID": request_id})
    else:
        response = client.get("/dashboard", headers={"X-Request-ID": request_id})
    assert _unavailable(response).headers["X-Request-ID"] == request_id


def test_an_unexpected_error_is_a_500_problem_with_the_request_id(app_and_client, monkeypatch):
    app, client = app_and_client

    def broken(*args, **kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(app.state.jobs.ctx.repo, "get", broken)
    response = client.get(f"/v1/jobs/{uuid.uuid4()}")
    assert response.status_code == 500 and response.headers["content-type"] == PROBLEM
    assert response.headers["X-Request-ID"] and "a bug" not in response.text


def test_the_database_back_answers_again(app_and_client, monkeypatch):
    app, client = app_and_client
    _database_away(app, monkeypatch, "create")
    _unavailable(client.post("/v1/test-compute/jobs", json={"values": [1]}))
    monkeypatch.undo()
    assert client.post("/v1/test-compute/jobs", json={"values": [1]}).status_code == 202
