"""A full disk is not a reason to solve again: the result's write is retried (RESULT_WRITE_SECONDS), then the job fails
once with a report saying a disk is full, never re-queued to solve the same input on the same full disk."""

from __future__ import annotations

import errno
import sqlite3
import uuid

import pytest
from sqlalchemy.exc import OperationalError

from plantsolve.jobs.attempts import disk_full, judge
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.spool import pending_artifact_key
from plantsolve.jobs.service import JobService
from plantsolve.store.blobs import BlobStoreUnavailable
from tests.conftest import service_settings
from tests.support.dispatch import Recorder


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, result_write_seconds=0.3), migrate=True)
    yield context
    context.close()


def _no_space(ctx, monkeypatch) -> list[str]:
    """The blob store's disk is full: every put fails as a full disk's write does (the keys tried are listed)."""
    tried: list[str] = []

    def put(key, data):
        tried.append(key)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ctx.files, "put", put)
    return tried


def test_artifacts_on_a_full_disk_fail_the_job_once_without_solving_again(ctx, tmp_path, monkeypatch):
    markers = tmp_path / "runs"
    queue = Recorder()
    job_id = JobService(ctx, queue).submit_json(
        "test-compute", f'{{"values": [3, 4], "marker_dir": "{markers}"}}'.encode(), None).job.id
    tried = _no_space(ctx, monkeypatch)
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "failed"
    assert len(list(markers.iterdir())) == 1  # solved once
    assert queue.enqueued == [job_id]  # the submission's; none for another attempt
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt) == ("failed", 1)
    assert [(h["attempt"], h["outcome"]) for h in job.attempts] == [(1, "failed")]
    report = job.report
    assert report["stage"] == "infrastructure" and report["details"] == {"disk_full": True}
    assert "disk of the service is full" in report["message"] and "No space left on device" in report["message"]
    assert "not retried" in report["message"]
    # the write was retried before it gave up (artifact puts), then the spool was tried on the same full disk
    assert tried.count(f"{job_id}/a1/values.txt") >= 2 and tried[-1] == pending_artifact_key(job_id, "values.txt")
    assert run_job(ctx, job_id, worker="w", requeue=queue.enqueue) == "skipped"


def test_a_solver_meeting_a_full_disk_fails_at_once_and_another_io_error_is_retried():
    job_id = uuid.uuid4()
    verdict = judge(OSError(errno.ENOSPC, "No space left on device"), job_id=job_id, attempt=1, max_attempts=3,
                    limits=(60, 90), elapsed=1.0)
    assert (verdict.outcome, verdict.retry) == ("failed", False)
    assert verdict.report["details"] == {"disk_full": True}
    assert judge(OSError(errno.EIO, "Input/output error"), job_id=job_id, attempt=1, max_attempts=3,
                 limits=(60, 90), elapsed=1.0).retry


@pytest.mark.parametrize("error, full", [
    (OSError(errno.ENOSPC, "No space left on device"), True),
    (OSError(errno.EDQUOT, "Disk quota exceeded"), True),
    (OSError(errno.EIO, "Input/output error"), False),
    (ConnectionError("refused"), False),
])
def test_disk_full_reads_the_errno_through_the_chain(error, full):
    assert disk_full(error) is full
    try:
        try:
            raise error
        except OSError as cause:
            raise BlobStoreUnavailable("the blob folder cannot be written") from cause
    except BlobStoreUnavailable as wrapped:
        assert disk_full(wrapped) is full


def _sqlite_error(*statements: str) -> sqlite3.OperationalError:
    connection = sqlite3.connect(":memory:")
    try:
        for statement in statements:
            connection.execute(statement)
    except sqlite3.OperationalError as error:
        return error
    finally:
        connection.close()
    raise AssertionError("no error")


def test_sqlites_full_database_is_a_full_disk():
    full = _sqlite_error("PRAGMA max_page_count = 2", "CREATE TABLE t (x BLOB)",
                         "INSERT INTO t VALUES (zeroblob(100000))")
    assert "full" in str(full)
    assert disk_full(OperationalError("INSERT INTO jobs ...", {}, full))
    assert not disk_full(OperationalError("SELECT ...", {}, _sqlite_error("SELECT * FROM missing")))
