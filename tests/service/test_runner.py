"""The runner's guarantees, driven by hand: claims are exclusive, writes are fenced on the
attempt, crashes retry up to the cap, hangs hit the time limit, lapsed leases are swept."""

from __future__ import annotations

import threading
import time
import uuid
from datetime import timedelta

import pytest
from sqlalchemy import update

from plantsolve.app.jobs.service import JobService
from plantsolve.workers.context import ServiceContext
from plantsolve.workers.sweeper import sweep_once
from plantsolve.store.models import Job, utcnow
from plantsolve.store.repository import StoredArtifact
from plantsolve.workers.runner import lost_worker_report, run_job
from tests.conftest import service_settings


class Recorder:
    def __init__(self):
        self.enqueued: list[uuid.UUID] = []

    def enqueue(self, job_id, kind=""):
        self.enqueued.append(job_id)

    def ping(self): ...
    def start(self): ...
    def stop(self): ...


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path), migrate=True)
    yield context
    context.close()


def submit(ctx, kind, body: bytes) -> uuid.UUID:
    return JobService(ctx, Recorder()).submit_json(kind, body, None).job.id


def test_stale_attempt_cannot_overwrite_newer_one(ctx):
    job_id = submit(ctx, "test-compute", b'{"values": [1]}')
    first = ctx.repo.claim(job_id, lease_seconds=60, worker="a")
    assert first == 1
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="b") is None  # lease still held
    with ctx.db.sessions() as session:  # the first worker goes silent: its lease lapses
        session.execute(update(Job).where(Job.id == job_id).values(lease_until=utcnow() - timedelta(seconds=1)))
        session.commit()
    second = ctx.repo.claim(job_id, lease_seconds=60, worker="b")
    assert second == 2
    assert not ctx.repo.heartbeat(job_id, first, lease_seconds=60)
    assert not ctx.repo.set_progress(job_id, first, 0.5, "late")
    artifact = StoredArtifact("x.txt", "text/plain", 1, "0" * 64, "x")
    assert not ctx.repo.finish_success(job_id, first, result={"stale": True}, report={}, artifacts=[artifact], run_seconds=1)
    assert not ctx.repo.finish_failure(job_id, first, report={"stale": True}, run_seconds=1)
    assert ctx.repo.finish_success(job_id, second, result={"fresh": True}, report={}, artifacts=[], run_seconds=1)
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt, job.result) == ("succeeded", 2, {"fresh": True})
    assert ctx.repo.artifacts(job_id) == []
    assert not ctx.repo.finish_success(job_id, first, result={"stale": True}, report={}, artifacts=[], run_seconds=1)
    assert ctx.repo.get(job_id).result == {"fresh": True}


def test_job_delivered_twice_runs_its_solver_once(ctx, tmp_path):
    markers = tmp_path / "runs"
    job_id = submit(ctx, "test-compute", f'{{"values": [2], "seconds": 0.5, "marker_dir": "{markers}"}}'.encode())
    outcomes: list[str] = []
    threads = [
        threading.Thread(target=lambda: outcomes.append(run_job(ctx, job_id, worker=f"w{i}", requeue=Recorder().enqueue)))
        for i in range(2)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(outcomes) == ["skipped", "succeeded"]
    assert len(list(markers.iterdir())) == 1
    job = ctx.repo.get(job_id)
    assert job.attempt == 1 and job.result["total"] == 2.0
    assert run_job(ctx, job_id, worker="late", requeue=Recorder().enqueue) == "skipped"  # a third, late delivery


def test_crashing_solver_retries_then_fails_with_a_report(ctx):
    job_id = submit(ctx, "test-crash", b'{"message": "division by zero"}')
    queue = Recorder()
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "requeued"
    assert queue.enqueued == [job_id]
    job = ctx.repo.get(job_id)
    assert job.status == "queued" and job.attempt == 1
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "failed"  # max_attempts=2 for this kind
    job = ctx.repo.get(job_id)
    assert job.status == "failed" and job.attempt == 2
    report = job.report
    assert report["status"] == "failed" and report["stage"] == "solver"
    assert "division by zero" in report["message"]
    assert [a["attempt"] for a in report["details"]["attempts"]] == [1, 2]
    assert "ConnectionError" in report["details"]["attempts"][0]["error"]
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "skipped"


@pytest.mark.parametrize("error", ["LinAlgError", "ValueError", "MemoryError"])
def test_a_failure_that_the_input_decides_fails_once_without_server_details(ctx, error):
    message = "SVD did not converge in /srv/plantsolve/.venv/lib/python3.11/site-packages/numpy/linalg/_linalg.py"
    job_id = submit(ctx, "test-crash", f'{{"message": "{message}", "error": "{error}"}}'.encode())
    queue = Recorder()
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "failed"
    assert queue.enqueued == []
    job = ctx.repo.get(job_id)
    assert job.status == "failed" and job.attempt == 1  # one attempt, not max_attempts
    report = job.report
    assert report["stage"] == "solver" and error in report["message"] and "not retried" in report["message"]
    text = str(report)
    assert "site-packages" not in text and "/srv/" not in text and "Traceback" not in text and "<path>" in text


def test_hanging_solver_hits_the_time_limit(ctx):
    job_id = submit(ctx, "test-hang", b"{}")
    started = time.monotonic()
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    assert time.monotonic() - started < 10
    job = ctx.repo.get(job_id)
    assert job.status == "failed" and job.report["stage"] == "time_limit"
    assert job.report["details"]["time_limit"] == 2.0


def test_cancel_running_job_stops_the_solver(ctx):
    job_id = submit(ctx, "test-compute", b'{"values": [1], "seconds": 20}')
    outcome: list[str] = []
    thread = threading.Thread(target=lambda: outcome.append(run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue)))
    thread.start()
    deadline = time.monotonic() + 10
    while ctx.repo.get(job_id).status != "running":
        assert time.monotonic() < deadline
        time.sleep(0.02)
    started = time.monotonic()
    assert JobService(ctx, Recorder()).cancel(job_id).status == "cancelled"
    thread.join(timeout=10)
    assert outcome == ["cancelled"] and time.monotonic() - started < 5
    job = ctx.repo.get(job_id)
    assert job.status == "cancelled" and job.result is None and job.report["stage"] == "cancelled"


def test_sweeper_requeues_lapsed_leases_and_fails_after_the_cap(ctx):
    job_id = submit(ctx, "test-compute", b'{"values": [1]}')
    queue = Recorder()
    for attempt in range(1, 4):
        assert ctx.repo.claim(job_id, lease_seconds=0.01, worker="dies") == attempt
        time.sleep(0.03)  # the worker was killed: no heartbeat, the lease lapses
        sweep_once(ctx, queue.enqueue)
    job = ctx.repo.get(job_id)
    assert job.status == "failed" and job.attempt == 3 == job.max_attempts
    assert job.report["stage"] == "worker" and len(job.report["details"]["attempts"]) == 3
    assert queue.enqueued.count(job_id) >= 2


def test_lost_worker_report_keeps_history():
    first = lost_worker_report(1, 3, None)
    second = lost_worker_report(2, 3, first)
    assert [a["attempt"] for a in second["details"]["attempts"]] == [1, 2]
    assert "re-queued" in second["message"]


def test_solver_deaf_to_cancellation_is_abandoned_at_the_hard_limit(ctx):
    job_id = submit(ctx, "test-stubborn", b"{}")
    started = time.monotonic()
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    assert 1.5 < time.monotonic() - started < 10
    assert ctx.repo.get(job_id).report["stage"] == "time_limit"
