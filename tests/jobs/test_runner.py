"""The runner's guarantees, driven by hand: claims are exclusive, writes are fenced on the
attempt, crashes retry up to the cap, hangs hit the time limit, lapsed leases are swept."""

from __future__ import annotations

import dataclasses
import json
import threading
import time
import uuid
from datetime import timedelta

import pytest
from sqlalchemy import update

from plantsolve.jobs.attempts import ResultPending, Stop, judge
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import sweep_once
from plantsolve.jobs.runner import lost_worker_report, run_job
from plantsolve.jobs.service import JobService
from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.solvers.base import Solved, SolverError
from plantsolve.store.models import Job, utcnow
from plantsolve.store.repository import StoredArtifact
from tests.conftest import service_settings
from tests.support.dispatch import Recorder
from tests.support.running import running_in_thread


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
    # a ConnectionError is the machine's: said so, not called a crash of the solver on this input
    assert report["status"] == "failed" and report["stage"] == "infrastructure"
    assert "division by zero" in report["message"] and "not on the input" in report["message"]
    # one history, the job's: the report says what happened in words
    assert [(a["attempt"], a["outcome"]) for a in job.attempts] == [(1, "requeued"), (2, "failed")]
    assert "attempts" not in report["details"]
    assert "ConnectionError" not in json.dumps(report)  # class names stay in the server log
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
    assert report["stage"] == "solver" and error not in report["message"] and "not retried" in report["message"]
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
    thread, outcome = running_in_thread(ctx, job_id)
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
    assert job.report["stage"] == "worker" and [a["outcome"] for a in job.attempts] == ["lost"] * 3
    assert queue.enqueued.count(job_id) >= 2


def test_lost_worker_report_says_whether_the_job_goes_on():
    assert "re-queued" in lost_worker_report(2, 3)["message"]
    assert "each of 3 attempts" in lost_worker_report(3, 3)["message"]


def test_solver_deaf_to_cancellation_is_abandoned_at_the_hard_limit(ctx):
    job_id = submit(ctx, "test-stubborn", b"{}")
    started = time.monotonic()
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    assert 1.5 < time.monotonic() - started < 10
    assert ctx.repo.get(job_id).report["stage"] == "time_limit"


class Broker(Recorder):
    """A queue that can lose its messages and say how many it holds."""

    def __init__(self, fail: bool = False):
        super().__init__()
        self.fail = fail
        self.held = 0

    def enqueue(self, job_id, kind=""):
        if self.fail:
            raise ConnectionError("broker down")
        super().enqueue(job_id, kind)
        self.held += 1

    def pending(self):
        return self.held


def test_a_failed_enqueue_is_sent_at_the_next_sweep(ctx):
    broker = Broker(fail=True)
    job_id = JobService(ctx, broker).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.get(job_id).enqueued_at is None  # stored, not marked as sent
    broker.fail = False
    sweep_once(ctx, broker.enqueue, broker.pending)  # no waiting period for a message that never left
    assert broker.enqueued == [job_id] and ctx.repo.get(job_id).enqueued_at is not None


def test_messages_lost_by_the_broker_are_sent_again_and_held_ones_are_not(ctx):
    broker = Broker()
    service = JobService(ctx, broker)
    ids = [service.submit_json("test-compute", f'{{"values": [{i}]}}'.encode(), None).job.id for i in range(3)]
    with ctx.db.sessions() as session:  # older than requeue_queued_after
        session.execute(update(Job).values(enqueued_at=utcnow() - timedelta(seconds=ctx.settings.requeue_queued_after + 1)))
        session.commit()
    broker.enqueued.clear()
    sweep_once(ctx, broker.enqueue, broker.pending)  # the broker still holds all three: nothing to do
    assert broker.enqueued == []
    broker.held = 1  # a restart lost two of them
    sweep_once(ctx, broker.enqueue, broker.pending)
    assert broker.enqueued == ids[:2]  # the two oldest are sent again


def test_time_limits_come_from_the_settings(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, time_limits={"test-hang": 0.5},
                                                     soft_time_limits={"test-hang": 0.2}), migrate=True)
    try:
        spec = context.spec("test-hang")
        assert context.limits(spec) == (0.2, 0.5)
        assert context.limits(context.spec("test-compute")) == (60.0, 90.0)
        job_id = JobService(context, Recorder()).submit_json("test-hang", b"{}", None).job.id
        started = time.monotonic()
        assert run_job(context, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
        assert time.monotonic() - started < 1.5
        assert context.repo.get(job_id).report["details"]["time_limit"] == 0.5
    finally:
        context.close()


def _db_down(calls: list, failures: int, real):
    from sqlalchemy.exc import OperationalError

    def flaky(*args, **kwargs):
        calls.append(1)
        if len(calls) <= failures:
            raise OperationalError("UPDATE jobs ...", {}, ConnectionError("server closed the connection"))
        return real(*args, **kwargs)

    return flaky


def test_a_result_write_that_hits_a_database_hiccup_is_retried(ctx, tmp_path, monkeypatch):
    markers = tmp_path / "runs"
    job_id = submit(ctx, "test-compute", f'{{"values": [2], "marker_dir": "{markers}"}}'.encode())
    calls: list = []
    monkeypatch.setattr(ctx.repo, "finish_success", _db_down(calls, 2, ctx.repo.finish_success))
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert job.attempt == 1 and job.result["total"] == 2.0 and len(calls) == 3
    assert [(h["attempt"], h["outcome"]) for h in job.attempts] == [(1, "succeeded")]
    assert len(list(markers.iterdir())) == 1


def test_progress_writes_that_hit_a_database_hiccup_do_not_cost_the_computation(ctx, tmp_path, monkeypatch):
    markers = tmp_path / "runs"
    job_id = submit(ctx, "test-compute", f'{{"values": [3], "seconds": 0.2, "marker_dir": "{markers}"}}'.encode())
    calls: list = []
    monkeypatch.setattr(ctx.settings, "progress_write_seconds", 0.0)
    monkeypatch.setattr(ctx.repo, "set_progress", _db_down(calls, 5, ctx.repo.set_progress))
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert job.attempt == 1 and job.result["total"] == 3.0 and len(calls) > 5
    assert len(list(markers.iterdir())) == 1


def test_a_result_the_database_never_took_is_stored_by_the_next_attempt_without_solving(tmp_path, monkeypatch):
    context = ServiceContext.create(service_settings(tmp_path, result_write_seconds=0.3), migrate=True)
    try:
        markers = tmp_path / "runs"
        job_id = submit(context, "test-compute", f'{{"values": [3], "marker_dir": "{markers}"}}'.encode())
        real = context.repo.finish_success
        monkeypatch.setattr(context.repo, "finish_success", _db_down([], 10**6, real))
        queue = Recorder()
        assert run_job(context, job_id, worker="w1", requeue=queue.enqueue) == "requeued"
        assert queue.enqueued == [job_id] and context.repo.get(job_id).status == "queued"
        monkeypatch.setattr(context.repo, "finish_success", real)  # the database is back
        assert run_job(context, job_id, worker="w2", requeue=queue.enqueue) == "succeeded"
        job = context.repo.get(job_id)
        assert job.result["total"] == 3.0 and len(list(markers.iterdir())) == 1  # solved once
        outcomes = [(h["attempt"], h["worker"], h["outcome"]) for h in job.attempts]
        assert outcomes == [(1, "w1", "result_pending"), (2, "w2", "succeeded")]
        assert "attempt 1" in job.attempts[1]["error"]
        view = JobService(context, Recorder()).view(job)
        assert [a.outcome for a in view.attempts] == ["result_pending", "succeeded"]
    finally:
        context.close()


def test_a_result_waiting_after_the_last_attempt_is_still_stored(tmp_path, monkeypatch):
    """The last attempt computed the result and the database took neither it nor the re-queue: the lease
    lapses, and the sweeper grants one attempt to store the result instead of failing the job as lost."""
    context = ServiceContext.create(service_settings(tmp_path, result_write_seconds=0.2, max_attempts=1), migrate=True)
    try:
        markers = tmp_path / "runs"
        job_id = submit(context, "test-compute", f'{{"values": [6], "marker_dir": "{markers}"}}'.encode())
        real_finish, real_requeue = context.repo.finish_success, context.repo.requeue
        monkeypatch.setattr(context.repo, "finish_success", _db_down([], 10**6, real_finish))
        monkeypatch.setattr(context.repo, "requeue", _db_down([], 10**6, real_requeue))
        with pytest.raises(Exception):
            run_job(context, job_id, worker="w1", requeue=Recorder().enqueue)
        monkeypatch.setattr(context.repo, "finish_success", real_finish)
        monkeypatch.setattr(context.repo, "requeue", real_requeue)
        assert context.repo.get(job_id).status == "running"
        with context.db.sessions() as session:  # the lease lapses
            session.execute(update(Job).where(Job.id == job_id).values(lease_until=utcnow() - timedelta(seconds=1)))
            session.commit()
        queue = Recorder()
        sweep_once(context, queue.enqueue)
        job = context.repo.get(job_id)
        assert job.status == "queued" and job.max_attempts == 2 and queue.enqueued == [job_id]
        assert run_job(context, job_id, worker="w2", requeue=queue.enqueue) == "succeeded"
        job = context.repo.get(job_id)
        assert job.result["total"] == 6.0 and len(list(markers.iterdir())) == 1
    finally:
        context.close()


def test_a_result_pending_on_the_last_attempt_gets_an_attempt_to_be_stored(tmp_path, monkeypatch):
    context = ServiceContext.create(service_settings(tmp_path, result_write_seconds=0.2, max_attempts=1), migrate=True)
    try:
        job_id = submit(context, "test-compute", b'{"values": [8]}')
        real = context.repo.finish_success
        monkeypatch.setattr(context.repo, "finish_success", _db_down([], 10**6, real))
        queue = Recorder()
        assert run_job(context, job_id, worker="w1", requeue=queue.enqueue) == "requeued"
        assert context.repo.get(job_id).max_attempts == 2
        monkeypatch.setattr(context.repo, "finish_success", real)
        assert run_job(context, job_id, worker="w2", requeue=queue.enqueue) == "succeeded"
        assert context.repo.get(job_id).result["total"] == 8.0
    finally:
        context.close()


def test_the_job_view_keeps_a_lost_attempt_after_a_later_success(ctx):
    job_id = submit(ctx, "test-compute", b'{"values": [4]}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="gone") == 1
    with ctx.db.sessions() as session:
        session.execute(update(Job).where(Job.id == job_id).values(lease_until=utcnow() - timedelta(seconds=1)))
        session.commit()
    sweep_once(ctx, Recorder().enqueue)
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert [(h["attempt"], h["worker"], h["outcome"]) for h in job.attempts] == [(1, "gone", "lost"), (2, "w", "succeeded")]


def test_a_job_shorter_than_the_write_interval_makes_no_progress_write_and_a_longer_one_coalesces(ctx, monkeypatch):
    monkeypatch.setattr(ctx.settings, "progress_write_seconds", 0.25)
    written: list[tuple[float, str]] = []
    real = ctx.repo.set_progress
    monkeypatch.setattr(ctx.repo, "set_progress",
                        lambda job_id, attempt, fraction, message: written.append((fraction, message)) or real(
                            job_id, attempt, fraction, message))
    quick = submit(ctx, "test-compute", b'{"values": [1]}')  # 20 progress reports within a few ms
    assert run_job(ctx, quick, worker="w", requeue=Recorder().enqueue) == "succeeded"
    assert written == []  # the claim wrote "started", the finish "done": nothing in between is worth a write
    slow = submit(ctx, "test-compute", b'{"values": [1], "seconds": 1.0}')  # 20 reports, 50 ms apart
    assert run_job(ctx, slow, worker="w", requeue=Recorder().enqueue) == "succeeded"
    # one write per 0.25 s interval, the first not before 0.25 s: about 3 of the 20 reports, each the latest
    assert 2 <= len(written) <= 5, written
    assert [f for f, _ in written] == sorted(f for f, _ in written) and written[0][0] >= 0.2


@pytest.mark.parametrize("error, attempt, outcome, retry", [
    (ConnectionError("reset"), 1, "requeued", True),  # the machine's services: retried
    (ConnectionError("reset"), 3, "failed", False),  # until the cap
    (ValueError("singular"), 1, "failed", False),  # the input decides: never retried
    (SolverError("fit", "no fit", {}), 1, "failed", False),
    (Stop("cancelled"), 1, "cancelled", False),
    (Stop("time_limit"), 1, "time_limit", False),
    (ResultPending("db away"), 3, "result_pending", True),
])
def test_the_retry_policy_is_one_function_of_the_error_and_the_attempt(error, attempt, outcome, retry):
    verdict = judge(error, job_id=uuid.uuid4(), attempt=attempt, max_attempts=3, limits=(1.0, 2.0), elapsed=0.5)
    assert (verdict.outcome, verdict.retry) == (outcome, retry)
    assert verdict.grant_attempt == isinstance(error, ResultPending)  # a waiting result gets the attempt it needs
    if outcome != "cancelled":
        assert verdict.report["status"] == "failed" and "attempts" not in verdict.report["details"]


def test_an_export_that_could_not_be_stored_is_a_warning_in_the_results_own_report_too(ctx, monkeypatch):
    """GET /result (and the CLI's output file) show the result's report: it must say what the job's report says,
    not "ok" beside a job whose artifact is missing."""
    job_id = submit(ctx, "test-compute", b'{"values": [2]}')
    real_put = ctx.files.put

    def put(key, data):
        if key.endswith("/values.txt"):
            raise ValueError("the blob store refused this name")
        return real_put(key, data)

    monkeypatch.setattr(ctx.files, "put", put)
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert [a.name for a in ctx.repo.artifacts(job_id)] == ["summary.json"]
    assert job.report["status"] == "warning"
    assert job.result["report"] == job.report
    assert [w["code"] for w in job.result["report"]["warnings"]] == ["artifacts_failed"]
    assert "values.txt" in job.result["report"]["warnings"][0]["message"]


def _spec_solving(ctx, monkeypatch, report: Report):
    """test-compute whose solver returns its result with ``report``."""
    spec = ctx.spec("test-compute")

    def solve(request, progress):
        solved = spec.solve(request, progress)
        return Solved(solved.result.model_copy(update={"report": report}))

    patched = dataclasses.replace(spec, solve=solve)
    real = ctx.spec
    monkeypatch.setattr(ctx, "spec", lambda kind: patched if kind == "test-compute" else real(kind))


def test_a_result_whose_own_report_says_failed_is_a_failed_job_not_a_succeeded_one(ctx, monkeypatch):
    _spec_solving(ctx, monkeypatch, Report(status="failed", stage="fit", message="The fit did not converge.",
                                           details={"residual": 3.5}))
    job_id = submit(ctx, "test-compute", b'{"values": [2]}')
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    job = ctx.repo.get(job_id)
    assert job.status == "failed" and job.result is None and ctx.repo.artifacts(job_id) == []
    assert (job.report["status"], job.report["stage"], job.report["message"]) == ("failed", "fit",
                                                                                  "The fit did not converge.")
    assert job.report["details"]["residual"] == 3.5


def test_a_result_reported_ok_beside_warnings_is_stored_as_warning(ctx, monkeypatch):
    warning = Diagnostic(code="not_converged", message="The fit stopped at its iteration limit.")
    _spec_solving(ctx, monkeypatch, Report(status="ok", message="computed", warnings=[warning]))
    job_id = submit(ctx, "test-compute", b'{"values": [2]}')
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert job.report["status"] == job.result["report"]["status"] == "warning"
    assert [w["code"] for w in job.result["report"]["warnings"]] == ["not_converged"]
