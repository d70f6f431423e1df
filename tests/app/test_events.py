"""Live progress over Server-Sent Events: a job's stream (its view, then every status or progress
change, then ``end``) and the stream of every job, both read from the database."""

from __future__ import annotations

import queue
import threading
import time
import uuid

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for
from tests.support.login import log_in
from tests.support.sse import events


def fast_events(tmp_path, **overrides):
    return service_settings(tmp_path, events_poll_seconds=0.05, events_ping_seconds=0.2, **overrides)


def test_a_running_job_streams_rising_progress_then_end(tmp_path):
    with TestClient(create_app(fast_events(tmp_path))) as client:
        job = client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0], "seconds": 2.0}).json()
        received = []
        with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
            assert response.status_code == 200
            assert response.headers["content-type"].startswith("text/event-stream")
            for name, data in events(response.iter_lines(), deadline=time.monotonic() + 30):
                received.append((name, data))
        names = [name for name, _ in received]
        assert names[-1] == "end" and set(names[:-1]) == {"job"}
        assert received[-1][1] == {"status": "succeeded"}
        views = [data for _, data in received[:-1]]
        fractions = [view["progress"]["fraction"] for view in views]
        assert fractions == sorted(fractions)  # progress never goes back
        assert len(set(fractions)) >= 5  # the solver reports 20 steps over 2 s; polled every 0.05 s
        # every event is a change of status or progress: no repeats
        changes = [(v["status"], v["progress"]["fraction"], v["progress"]["message"]) for v in views]
        assert len(changes) == len(set(changes))
        # the last job event is the finished job, exactly as GET /v1/jobs/{id} shows it
        assert views[-1] == client.get(f"/v1/jobs/{job['id']}").json()
        assert views[-1]["status"] == "succeeded" and views[-1]["artifacts"]


def test_the_stream_of_a_finished_job_is_its_view_then_end(tmp_path):
    with TestClient(create_app(fast_events(tmp_path))) as client:
        job = wait_for(client, client.post("/v1/test-fail/jobs", json={"message": "no fit"}).json()["id"])
        with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
            received = list(events(response.iter_lines(), deadline=time.monotonic() + 10))
        assert received == [("job", client.get(f"/v1/jobs/{job['id']}").json()), ("end", {"status": "failed"})]


def _drive(app, job_id: uuid.UUID, pause: float, seen: "queue.Queue | None" = None) -> threading.Thread:
    """Play a worker by writing straight into the database, as a Celery worker on another host would. With
    ``seen``, each write waits until the reader has taken the previous state off the stream (no poll can miss
    a state on a slow machine)."""
    repo = app.state.ctx.repo

    def step() -> None:
        if seen is not None:
            seen.get(timeout=20)
        time.sleep(pause)

    def steps() -> None:
        step()
        attempt = repo.claim(job_id, lease_seconds=30, worker="elsewhere")
        for fraction, message in ((0.25, "fitting"), (0.5, "fitting"), (0.5, "rendering")):
            step()
            repo.set_progress(job_id, attempt, fraction, message)
        step()
        repo.finish_success(job_id, attempt, result={"total": 1.0}, report={"status": "ok", "message": "done"},
                            artifacts=[], run_seconds=0.1)

    thread = threading.Thread(target=steps, daemon=True)
    thread.start()
    return thread


def test_events_come_from_the_database_not_from_the_process(tmp_path):
    # no job runs in this process: every change is a row written by "another worker"
    app = create_app(fast_events(tmp_path), run_jobs=False)
    with TestClient(app) as client:
        job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
        seen: queue.Queue = queue.Queue()
        writer = _drive(app, uuid.UUID(job["id"]), pause=0.1, seen=seen)
        received = []
        with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
            for name, data in events(response.iter_lines(), deadline=time.monotonic() + 30):
                received.append((name, data))
                seen.put(name)
        writer.join()
    states = [(d["status"], d["progress"]["fraction"], d["progress"]["message"]) for n, d in received if n == "job"]
    assert states == [
        ("queued", 0.0, "queued"),
        ("running", 0.0, "started"),
        ("running", 0.25, "fitting"),
        ("running", 0.5, "fitting"),
        ("running", 0.5, "rendering"),  # a new message alone is a change
        ("succeeded", 1.0, "done"),
    ]
    assert received[-1] == ("end", {"status": "succeeded"})


def test_the_stream_of_every_job_sends_changes_after_connect_filtered_by_kind(tmp_path):
    app = create_app(fast_events(tmp_path), run_jobs=False)
    with TestClient(app) as client:
        before = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()  # unchanged: never sent
        comments: list[str] = []
        received: list[tuple[str, str, float]] = []
        ids: set[str] = set()
        with client.stream("GET", "/v1/jobs/events", params={"kind": "test-compute"}) as response:
            assert response.status_code == 200
            lines = response.iter_lines()
            assert next(lines).startswith(":")  # the stream is open before anything happens

            seen: queue.Queue = queue.Queue()

            def submit_and_run() -> None:
                client.post("/v1/test-fail/jobs", json={})  # another kind: filtered out
                job = client.post("/v1/test-compute/jobs", json={"values": [2.0]}).json()
                _drive(app, uuid.UUID(job["id"]), pause=0.1, seen=seen).join()

            threading.Thread(target=submit_and_run, daemon=True).start()
            for name, data in events(lines, deadline=time.monotonic() + 30, comments=comments):
                received.append((data["kind"], data["status"], data["progress"]["fraction"]))
                ids.add(data["id"])
                seen.put(name)
                if data["status"] == "succeeded":
                    break
        assert all(kind == "test-compute" for kind, _, _ in received)
        assert len(ids) == 1 and before["id"] not in ids
        assert [status for _, status, _ in received][0] == "queued"  # the new job, as it appeared
        assert [fraction for _, _, fraction in received] == sorted(fraction for _, _, fraction in received)
        assert ("test-compute", "running", 0.25) in received and received[-1][1:] == ("succeeded", 1.0)
        assert any(comment.startswith("ping") for comment in comments)  # the keep-alive


def test_the_stream_of_every_job_filters_by_status(tmp_path):
    app = create_app(fast_events(tmp_path), run_jobs=False)
    with TestClient(app) as client:
        with client.stream("GET", "/v1/jobs/events", params={"status": "succeeded"}) as response:
            lines = response.iter_lines()
            next(lines)
            job = client.post("/v1/test-compute/jobs", json={"values": [2.0]}).json()
            _drive(app, uuid.UUID(job["id"]), pause=0.1)
            name, data = next(events(lines, deadline=time.monotonic() + 20))
        assert (name, data["id"], data["status"]) == ("job", job["id"], "succeeded")


def test_bad_stream_parameters_are_422_problems(client):
    for path, params, loc in (("/v1/jobs/events", {"status": "done"}, ["query", "status"]),
                              ("/v1/jobs/not-a-uuid/events", {}, ["path", "job_id"])):
        response = client.get(path, params=params)
        assert response.status_code == 422 and response.headers["content-type"] == "application/problem+json"
        assert response.json()["errors"][0]["loc"] == loc


@pytest.fixture
def tenants(tmp_path):
    settings = fast_events(tmp_path, api_keys=["alice:key-a", "bob:key-b"])
    with TestClient(create_app(settings)) as client:
        yield client


def test_event_streams_need_a_key_and_hide_other_tenants_jobs(tenants):
    client = tenants
    alice, bob = {"Authorization": "Bearer key-a"}, {"Authorization": "Bearer key-b"}
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=alice).json()
    wait_for(client, job["id"], headers=alice)
    assert client.get(f"/v1/jobs/{job['id']}/events").status_code == 401
    foreign = client.get(f"/v1/jobs/{job['id']}/events", headers=bob)
    assert foreign.status_code == 404 and foreign.headers["content-type"] == "application/problem+json"
    assert client.get(f"/v1/jobs/{uuid.uuid4()}/events", headers=alice).status_code == 404
    # the dashboard's log-in cookie is good for reads, so a browser's EventSource can follow a job
    log_in(client, "key-a")
    with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
        received = list(events(response.iter_lines(), deadline=time.monotonic() + 10))
    client.cookies.clear()
    assert [name for name, _ in received] == ["job", "end"] and received[0][1]["id"] == job["id"]


def test_the_stream_of_every_job_shows_only_the_callers_jobs(tenants):
    client = tenants
    alice, bob = {"Authorization": "Bearer key-a"}, {"Authorization": "Bearer key-b"}
    received = []
    with client.stream("GET", "/v1/jobs/events", headers=bob) as response:
        lines = response.iter_lines()
        next(lines)
        wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=alice).json()["id"],
                 headers=alice)
        mine = client.post("/v1/test-compute/jobs", json={"values": [2.0]}, headers=bob).json()
        for name, data in events(lines, deadline=time.monotonic() + 20):
            received.append(data["id"])
            if data["status"] == "succeeded":
                break
    assert set(received) == {mine["id"]}


def test_a_stream_stops_reading_the_database_when_its_client_goes_away(tmp_path):
    import httpx

    from tests.support.live import live_server

    app = create_app(fast_events(tmp_path), run_jobs=False)  # the job stays queued: the stream would never end
    polls: list[float] = []
    read_state = app.state.ctx.repo.state
    app.state.ctx.repo.state = lambda job_id: (polls.append(time.monotonic()), read_state(job_id))[1]
    with live_server(app) as url:
        job = httpx.post(f"{url}/v1/test-compute/jobs", json={"values": [1.0]}).json()
        with httpx.stream("GET", f"{url}/v1/jobs/{job['id']}/events") as response:
            lines = response.iter_lines()  # kept open: leaving a for loop early would close the connection
            while not next(lines).startswith("data:"):
                pass
            time.sleep(0.3)
            assert polls  # it polls while the client is connected
        # the with block closed the connection
        time.sleep(0.3)  # the server notices the closed connection
        settled = len(polls)
        time.sleep(0.5)
        assert len(polls) == settled  # and stopped after the client left
