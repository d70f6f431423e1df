"""A Celery worker whose disk is below MIN_FREE_DISK_BYTES starts no job, as the built-in pools do
(``jobs/holds.py``): the job stays queued saying "waiting: disk space low", its task asking again after
``held_countdown`` (2, 4, 8 … s, up to half of REQUEUE_QUEUED_AFTER), and runs once on a worker with room, as its first attempt. Before, a Celery worker
started it anyway (a solve that could find no room for its result). Real PostgreSQL, Redis and ``plantsolve worker``
subprocesses, as ``test_integration_celery.py``."""

from __future__ import annotations

import time
import uuid
from datetime import datetime, timezone

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs.holds import DISK_WAIT, held_countdown
from tests.conftest import service_settings, wait_for
from tests.workers.test_integration_celery import ALIVE, Worker, _env

pytestmark = pytest.mark.integration

NO_DISK = str(2 ** 62)  # a floor no disk reaches


def test_a_held_tasks_wait_doubles_up_to_half_of_requeue_queued_after():
    assert [held_countdown(r, 20.0) for r in range(6)] == [2.0, 4.0, 8.0, 10.0, 10.0, 10.0]
    assert held_countdown(0, 1.5) == 2.0 and held_countdown(1000, 60.0) == 30.0


def test_a_celery_worker_holds_queued_jobs_while_its_disk_is_low(pg_url, redis_url, tmp_path):
    env = _env(pg_url, redis_url, tmp_path)
    settings = service_settings(tmp_path, database_url=pg_url, broker_url=redis_url, heartbeat_seconds=0.3,
                                lease_seconds=2.0, sweep_seconds=0.5, worker_beat_seconds=0.3,
                                worker_alive_seconds=ALIVE)  # the API has room: it takes the submissions
    with TestClient(create_app(settings)) as client:
        short = Worker({**env, "MIN_FREE_DISK_BYTES": NO_DISK}, "short", tmp_path / "worker-short.log")
        try:
            jobs = [client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0 * i]}).json()["id"] for i in (1, 2)]
            deadline = time.monotonic() + 30
            while not all(client.get(f"/v1/jobs/{job}").json()["progress"]["message"] == DISK_WAIT for job in jobs):
                assert time.monotonic() < deadline, [client.get(f"/v1/jobs/{job}").json() for job in jobs]
                time.sleep(0.1)
            time.sleep(8.0)  # held over several countdowns, not started nor failed
            for job in jobs:
                # its message is sent again with each countdown: the sweeper (a queued job's message older than
                # REQUEUE_QUEUED_AFTER is taken for lost) sends no other
                sent = client.app.state.ctx.repo.get(uuid.UUID(job)).enqueued_at
                age = (datetime.now(timezone.utc) - sent).total_seconds()
                assert age < client.app.state.ctx.settings.requeue_queued_after, age
                view = client.get(f"/v1/jobs/{job}").json()
                assert (view["status"], view["attempt"], view["progress"]["message"]) == ("queued", 0, DISK_WAIT)
                assert view["summary"].startswith("Waiting: disk space low")
        finally:
            short.stop()  # its held messages go back to the queue (acks_late)
        roomy = Worker(env, "roomy", tmp_path / "worker-roomy.log")
        try:
            for job, norm in zip(jobs, (5.0, (9 + 64) ** 0.5)):
                done = wait_for(client, job, timeout=60)
                assert (done["status"], done["attempt"]) == ("succeeded", 1), done
                assert client.get(f"/v1/jobs/{job}/result").json()["norm"] == pytest.approx(norm, rel=1e-15)
        finally:
            roomy.stop()
