"""A job that runs out of memory ends failed with a report that says so: a solver's MemoryError at once (the same
input needs the same memory), a job process killed by SIGKILL (the kernel's out-of-memory killer) after the attempt
cap, the report naming how the last attempt was lost instead of a worker that "stopped responding"."""

from __future__ import annotations

import signal
import uuid

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import process_died
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from tests.conftest import service_settings
from tests.support.dispatch import Recorder


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, max_attempts=2), migrate=True)
    yield context
    context.close()


def _submit(ctx, kind: str, body: bytes) -> uuid.UUID:
    return JobService(ctx, Recorder()).submit_json(kind, body, None).job.id


def test_a_bare_memory_error_fails_once_with_a_report_that_memory_ran_out(ctx):
    job_id = _submit(ctx, "test-crash", b'{"message": "", "error": "MemoryError"}')  # as numpy raises it: no words
    queue = Recorder()
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "failed"
    job = ctx.repo.get(job_id)
    assert queue.enqueued == [] and job.status == "failed" and job.attempt == 1  # not retried
    # before: "The solver failed on this input (internal error) ... Check the input's values (scale, ...)"
    assert job.report["stage"] == "solver"
    assert job.report["message"].startswith("The solver ran out of memory on this input; it was not retried")
    assert "internal error" not in job.report["message"]
    assert [(a["outcome"], a["error"]) for a in job.attempts] == [("failed", "out of memory")]


def test_a_job_process_killed_by_sigkill_on_every_attempt_fails_with_a_report_that_names_the_kill(ctx):
    job_id = _submit(ctx, "test-compute", b'{"values": [1]}')
    fates, reports = [], []
    for attempt in (1, 2):  # max_attempts=2
        worker = f"process@host:{100 + attempt}"
        assert ctx.repo.claim(job_id, lease_seconds=60, worker=worker) == attempt
        fates.append(process_died(ctx, job_id, worker, -signal.SIGKILL))
        reports.append(ctx.repo.get(job_id).report["message"])
    job = ctx.repo.get(job_id)
    assert fates == ["requeued", "failed"] and job.status == "failed"
    # before: "The worker stopped responding; ..." and "The job's worker stopped responding on each of 2 attempts"
    killed = ("the job process was killed by signal 9 (SIGKILL: sent by the kernel when memory runs out, or by an "
              "operator)")
    assert reports == [f"The worker was lost (the last: {killed}); the job was re-queued.",
                       f"The job's worker was lost on each of 2 attempts (the last: {killed}); giving up."]
    assert [(a["outcome"], a["error"]) for a in job.attempts] == [("lost", killed)] * 2


def test_a_job_process_that_exited_is_not_said_to_have_run_out_of_memory(ctx):
    job_id = _submit(ctx, "test-compute", b'{"values": [1]}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="process@host:7") == 1
    assert process_died(ctx, job_id, "process@host:7", 3) == "requeued"
    assert ctx.repo.get(job_id).report["message"] == \
        "The worker was lost (the last: the job process exited with code 3); the job was re-queued."
