"""Event streams and a database that goes away: an open stream pauses (its pings go on) and sends what happened
once the database is back, instead of breaking off mid-body with an error in the log; a stream asked for while
the database is away is a 503 problem, as every other request."""

from __future__ import annotations

import logging
import time
import uuid

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.exc import OperationalError

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.sse import events


def _away(*args, **kwargs):
    raise OperationalError("SELECT 1", {}, ConnectionRefusedError("connection refused"))


class Outage:
    """Stands in for a repository read: while ``away``, a call finds the database away."""

    def __init__(self, read):
        self.read, self.away, self.refused = read, False, 0

    def __call__(self, *args, **kwargs):
        if self.away:
            self.refused += 1
            _away()
        return self.read(*args, **kwargs)

    def back_after(self, polls: int) -> None:
        """The database comes back once the stream has polled it ``polls`` times in vain."""
        deadline = time.monotonic() + 10
        while self.refused < polls:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        self.away = False


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    """One service for these tests (a start costs a second): each test's outage is its own monkeypatch."""
    settings = service_settings(tmp_path_factory.mktemp("events"), events_poll_seconds=0.02, events_ping_seconds=0.2)
    app = create_app(settings, run_jobs=False)
    with TestClient(app, raise_server_exceptions=False) as client:  # a stream's error breaks its body off
        yield app, client


def _finish(repo, job_id: uuid.UUID) -> None:
    """Play a worker elsewhere: the job runs and succeeds (straight into the database)."""
    attempt = repo.claim(job_id, lease_seconds=30, worker="elsewhere")
    repo.finish_success(job_id, attempt, result={"total": 1.0}, report={"status": "ok", "message": "done"},
                        artifacts=[], run_seconds=0.1)


def test_a_jobs_stream_pauses_while_the_database_is_away_and_ends_once_it_is_back(service, monkeypatch, caplog):
    app, client = service
    repo = app.state.ctx.repo
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
    outage = Outage(repo.state)
    monkeypatch.setattr(repo, "state", outage)
    with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
        lines = response.iter_lines()
        received = [next(events(lines, deadline=time.monotonic() + 10))]
        outage.away = True  # the database goes away; meanwhile the job ends elsewhere
        _finish(repo, uuid.UUID(job["id"]))
        outage.back_after(5)
        received += list(events(lines, deadline=time.monotonic() + 10))
    # before: the first refused poll broke the body off ("Exception in ASGI application"), no end was sent
    assert outage.refused >= 5
    assert [(name, data.get("status")) for name, data in received] == \
        [("job", "queued"), ("job", "succeeded"), ("end", "succeeded")]
    paused = [r for r in caplog.records if "event stream" in r.getMessage()]
    assert len(paused) == 1 and paused[0].levelno == logging.WARNING  # once per outage, not once per poll


def test_the_stream_of_every_job_sends_a_job_created_and_finished_while_the_database_was_away(service, monkeypatch):
    app, client = service
    repo = app.state.ctx.repo
    outage = Outage(repo.states)
    monkeypatch.setattr(repo, "states", outage)
    with client.stream("GET", "/v1/jobs/events") as response:
        lines = response.iter_lines()
        assert next(lines).startswith(":")  # open
        outage.away = True
        job = client.post("/v1/test-compute/jobs", json={"values": [2.0]}).json()  # the insert gets through
        _finish(repo, uuid.UUID(job["id"]))
        outage.back_after(5)
        name, view = next(events(lines, deadline=time.monotonic() + 10))
    # before: the first refused poll broke the stream off; a poll that skipped forward in time would miss the job
    assert outage.refused >= 5
    assert (name, view["id"], view["status"]) == ("job", job["id"], "succeeded")


def test_the_stream_of_every_job_asked_for_while_the_database_is_away_is_a_503_problem(service, monkeypatch):
    app, client = service
    monkeypatch.setattr(app.state.ctx.repo, "states", _away)
    response = client.get("/v1/jobs/events")
    # before: 200 and a text/event-stream that broke off at once
    assert response.status_code == 503
    assert response.headers["content-type"] == "application/problem+json"
    assert int(response.headers["Retry-After"]) > 0


@pytest.mark.parametrize("path", ["job", "/v1/jobs/events"])
def test_a_stream_whose_database_stays_away_ends_with_a_problem_and_a_retry_hint(tmp_path, monkeypatch, caplog, path):
    """EVENTS_OUTAGE_SECONDS bounds the pause: then an `error` event (a 503 problem) with `retry` and the stream ends.
    Before, the stream paused with pings for as long as the database was away, and said nothing."""
    settings = service_settings(tmp_path, events_poll_seconds=0.02, events_ping_seconds=0.1,
                                events_outage_seconds=0.5)
    app = create_app(settings, run_jobs=False)
    with TestClient(app, raise_server_exceptions=False) as client:
        repo = app.state.ctx.repo
        job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
        url = f"/v1/jobs/{job['id']}/events" if path == "job" else path
        outage = Outage(repo.state if path == "job" else repo.states)
        monkeypatch.setattr(repo, "state" if path == "job" else "states", outage)
        lines: list[str] = []
        with client.stream("GET", url) as response:
            assert response.status_code == 200
            iterator = response.iter_lines()
            for line in iterator:
                lines.append(line)
                if line.startswith(("event: job", ": watching")):
                    break
            outage.away = True  # and stays away
            started = time.monotonic()
            for line in iterator:  # the stream ends by itself (pings keep the lines coming meanwhile)
                lines.append(line)
                assert time.monotonic() - started < 10, "the stream did not end while the database stayed away"
            paused = time.monotonic() - started
    assert outage.refused >= 2
    assert 0.5 <= paused < 10, paused
    received = list(events(iter(lines)))
    name, problem = received[-1]
    assert name == "error"
    assert problem["status"] == 503 and problem["type"].endswith("/unavailable") and problem["instance"] == url
    assert "unreachable for 0.5 s" in problem["detail"] and problem["extra"] == {"retry_after": 5}
    assert "retry: 5000" in lines[lines.index("event: error"):]  # the reconnection delay, in milliseconds
    assert [r.getMessage() for r in caplog.records if "ended: the database" in r.getMessage()]
