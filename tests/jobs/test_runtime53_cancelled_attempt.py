"""A cancelled running job keeps its attempt in the history, outcome ``cancelled``, like every attempt that ended."""

from __future__ import annotations

import uuid

import pytest

from plantsolve.jobs.errors import Conflict
from plantsolve.jobs.leases import process_died
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from tests.support.dispatch import Recorder
from tests.support.running import running_in_thread


def _submit(ctx, body: bytes) -> uuid.UUID:
    return JobService(ctx, Recorder()).submit_json("test-compute", body, None).job.id


def _history(ctx, job_id) -> list[tuple]:
    return [(h["attempt"], h.get("worker"), h["outcome"]) for h in ctx.repo.get(job_id).attempts or []]


def test_a_running_job_cancelled_ends_its_attempt_as_cancelled(ctx):
    job_id = _submit(ctx, b'{"values": [1], "seconds": 20}')
    thread, outcome = running_in_thread(ctx, job_id)
    view = JobService(ctx, Recorder()).view(JobService(ctx, Recorder()).cancel(job_id))
    assert [(a.attempt, a.worker, a.outcome) for a in view.attempts] == [(1, "w", "cancelled")]  # main: []
    assert view.attempts[0].finished_at is not None
    thread.join(timeout=10)
    assert outcome == ["cancelled"]
    assert _history(ctx, job_id) == [(1, "w", "cancelled")]  # the stopped attempt wrote nothing over it


def test_a_queued_job_cancelled_after_a_lost_attempt_keeps_that_history_alone(ctx):
    job_id = _submit(ctx, b'{"values": [1]}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="gone") == 1
    assert process_died(ctx, job_id, "gone", -9) == "requeued"
    JobService(ctx, Recorder()).cancel(job_id)
    assert _history(ctx, job_id) == [(1, "gone", "lost")]  # no attempt ran when it was cancelled


def test_a_cancel_that_races_a_claim_records_the_attempt_the_claim_started(ctx, monkeypatch):
    """The job is claimed between the cancel's read and its write: the write, made for a queued job, changes nothing,
    and the cancel reads the job again and ends the attempt that is now running."""
    job_id = _submit(ctx, b'{"values": [1]}')
    real = ctx.repo.cancel
    calls = []

    def claimed_meanwhile(*args, **kwargs):
        calls.append(kwargs["seen"])
        if len(calls) == 1:
            assert ctx.repo.claim(job_id, lease_seconds=60, worker="w") == 1
        return real(*args, **kwargs)

    monkeypatch.setattr(ctx.repo, "cancel", claimed_meanwhile)
    assert JobService(ctx, Recorder()).cancel(job_id).status == "cancelled"
    assert calls == [("queued", 0), ("running", 1)]
    assert _history(ctx, job_id) == [(1, "w", "cancelled")]


def test_a_repeated_cancel_is_answered_as_the_first_and_a_finished_job_is_refused_one(ctx):
    job_id = _submit(ctx, b'{"values": [1], "seconds": 20}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w") == 1
    service = JobService(ctx, Recorder())
    first = service.cancel(job_id)
    assert service.cancel(job_id).finished_at == first.finished_at
    assert _history(ctx, job_id) == [(1, "w", "cancelled")]
    done = _submit(ctx, b'{"values": [1]}')
    assert run_job(ctx, done, worker="w", requeue=Recorder().enqueue) == "succeeded"
    with pytest.raises(Conflict):
        service.cancel(done)
