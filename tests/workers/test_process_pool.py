"""The embedded default: jobs run in supervised worker processes, never in the API process."""

from __future__ import annotations

import os
import socket
import threading
import time
import uuid

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.workers.processes import worker_of
from tests.conftest import service_settings, wait_for


@pytest.fixture(scope="module")
def pooled(tmp_path_factory):
    settings = service_settings(tmp_path_factory.mktemp("pool"), embedded_mode="process", embedded_workers=2)
    with TestClient(create_app(settings)) as client:
        yield client


def test_jobs_run_in_worker_processes(pooled):
    job = pooled.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0], "seconds": 1.0}).json()
    wait_for(pooled, job["id"], statuses=("running",), timeout=60)
    worker_pid = pooled.app.state.dispatcher.running()[uuid.UUID(job["id"])]
    # the job process yields the CPU to the API process it shares the machine with
    assert os.getpriority(os.PRIO_PROCESS, worker_pid) == min(19, os.getpriority(os.PRIO_PROCESS, 0) + 10)
    done = wait_for(pooled, job["id"], timeout=60)
    assert done["status"] == "succeeded"
    assert pooled.get(f"/v1/jobs/{job['id']}/result").json()["norm"] == 5.0
    (attempt,) = done["attempts"]
    assert attempt["worker"] == worker_of(worker_pid) and worker_pid != os.getpid()
    assert attempt["worker"].startswith(f"process@{socket.gethostname()}~")  # with its pid namespace


def test_a_backlog_waits_in_the_database_and_is_resumed_after_a_stop(tmp_path, caplog):
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=1)
    with TestClient(create_app(settings)) as client:
        ids = [client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 0.2}).json()["id"]
               for _ in range(30)]
        # a backlog waits in its rows, not in the API process: the pool holds at most its window
        assert client.app.state.dispatcher.in_flight() <= client.app.state.dispatcher.window == 4
    assert not [r for r in caplog.records if r.levelname == "ERROR"]
    with TestClient(create_app(settings)) as client:  # the next start resumes the backlog
        assert all(wait_for(client, job_id, timeout=90)["status"] == "succeeded" for job_id in ids)


def test_a_backlog_beyond_the_window_is_pulled_in_as_jobs_finish_without_waiting_for_a_sweep(tmp_path):
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=1, sweep_seconds=600.0)
    with TestClient(create_app(settings)) as client:
        assert client.post("/v1/test-compute/jobs", json={"values": [0.0]}).status_code == 202  # the pool is up
        wait_for(client, client.get("/v1/jobs").json()["items"][0]["id"], timeout=60)
        ids = [client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 0.05}).json()["id"]
               for _ in range(3 * client.app.state.dispatcher.window)]
        assert all(wait_for(client, job_id, timeout=60)["status"] == "succeeded" for job_id in ids)


def test_a_solver_deaf_to_its_soft_limit_is_killed_at_the_hard_limit(pooled):
    before = {thread.ident for thread in threading.enumerate()}
    started = time.monotonic()
    job = pooled.post("/v1/test-stubborn/jobs", json={}).json()
    done = wait_for(pooled, job["id"], timeout=60)
    assert done["status"] == "failed" and done["report"]["stage"] == "time_limit"
    assert done["report"]["details"]["killed"] is True
    assert time.monotonic() - started < 30
    assert [a["outcome"] for a in done["attempts"]] == ["time_limit"]
    # the API process kept no thread of the killed solver, and jobs still run. Not counted: the request thread
    # pool's idle workers (anyio ends them after 10 s)
    new = [t.name for t in threading.enumerate() if t.ident not in before and t.name != "AnyIO worker thread"]
    assert new == [], new
    again = pooled.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
    assert wait_for(pooled, again["id"], timeout=60)["status"] == "succeeded"


def test_an_infrastructure_crash_is_retried_through_the_pool(pooled):
    job = pooled.post("/v1/test-crash/jobs", json={"message": "connection reset"}).json()
    done = wait_for(pooled, job["id"], timeout=60)
    assert done["status"] == "failed" and done["attempt"] == 2
    assert [a["outcome"] for a in done["attempts"]] == ["requeued", "failed"]
