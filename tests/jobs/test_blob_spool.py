"""A computed result the database did not take waits in the blob store, where a worker on another machine
(another DATA_DIR) stores it without solving again; when the blob store is away too (the PostgreSQL back-end
during a database outage), the result and the artifacts not yet stored wait in this machine's folder."""

from __future__ import annotations

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.spool import pending_artifact_key, pending_path
from plantsolve.jobs.service import JobService
from plantsolve.store.blobs import BlobStoreUnavailable
from tests.conftest import service_settings
from tests.store.s3_server import moto_s3
from tests.support.dispatch import Recorder


def _database_away(*args, **kwargs):
    from sqlalchemy.exc import OperationalError

    raise OperationalError("UPDATE jobs ...", {}, ConnectionError("server closed the connection"))


def _machine(tmp_path, name: str, **settings) -> ServiceContext:
    """A process on its own machine: its own DATA_DIR, the shared database."""
    return ServiceContext.create(service_settings(tmp_path / name, database_url=f"sqlite:///{tmp_path / 'jobs.db'}",
                                                  result_write_seconds=0.3, **settings), migrate=True)


def _download(ctx, job_id, name) -> bytes:
    return JobService(ctx, Recorder()).artifact(job_id, name)[1].read()


def test_a_result_spooled_in_s3_is_stored_by_a_worker_on_another_machine_without_solving(tmp_path, monkeypatch):
    with moto_s3() as env:
        s3 = {"blob_store": "s3", "s3_bucket": env["S3_BUCKET"], "s3_endpoint_url": env["S3_ENDPOINT_URL"]}
        first, second = _machine(tmp_path, "one", **s3), _machine(tmp_path, "two", **s3)
        try:
            markers = tmp_path / "runs"
            job_id = JobService(first, Recorder()).submit_json(
                "test-compute", f'{{"values": [3, 4], "marker_dir": "{markers}"}}'.encode(), None).job.id
            monkeypatch.setattr(first.repo, "finish_success", _database_away)
            assert run_job(first, job_id, worker="w1", requeue=Recorder().enqueue) == "requeued"
            assert first.files.exists(pending_path(job_id))  # in the bucket, not on machine one's disk
            assert run_job(second, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
            job = second.repo.get(job_id)
            assert job.result["norm"] == 5.0 and len(list(markers.iterdir())) == 1  # solved once
            assert [(h["worker"], h["outcome"]) for h in job.attempts] == [("w1", "result_pending"), ("w2", "succeeded")]
            assert _download(second, job_id, "values.txt") == b"3.0\n4.0"
            assert not second.files.exists(pending_path(job_id))  # the spool is gone once the result is written
            for machine in ("one", "two"):
                assert not [p for p in (tmp_path / machine).rglob("*") if p.is_file() and "artifacts" in p.parts]
        finally:
            first.close()
            second.close()


def test_when_the_blob_store_is_away_too_the_result_and_its_artifacts_wait_on_this_machine(tmp_path, monkeypatch):
    ctx = _machine(tmp_path, "one", blob_store="postgres")  # the database table back-end (here on SQLite)
    try:
        markers = tmp_path / "runs"
        job_id = JobService(ctx, Recorder()).submit_json(
            "test-compute", f'{{"values": [6, 8], "marker_dir": "{markers}"}}'.encode(), None).job.id
        put = ctx.files.put

        def away(key, data):
            raise BlobStoreUnavailable("the database holding the blobs is unreachable")

        monkeypatch.setattr(ctx.files, "put", away)
        monkeypatch.setattr(ctx.repo, "finish_success", _database_away)
        assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "requeued"
        assert ctx.spool.exists(pending_path(job_id))  # this machine's folder took it
        assert ctx.spool.get(pending_artifact_key(job_id, "values.txt")) == b"6.0\n8.0"
        monkeypatch.undo()  # the database is back
        assert ctx.files.put == put
        assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "succeeded"
        job = ctx.repo.get(job_id)
        assert job.result["norm"] == 10.0 and len(list(markers.iterdir())) == 1  # solved once
        assert not (job.report or job.result["report"]).get("warnings")  # no artifact was dropped
        assert _download(ctx, job_id, "values.txt") == b"6.0\n8.0"  # now in the blob store
        assert not ctx.spool.exists(pending_path(job_id))
        assert not ctx.spool.exists(pending_artifact_key(job_id, "values.txt"))
    finally:
        ctx.close()


@pytest.mark.parametrize("kind", ["upload", "json_file"])
def test_a_submitted_input_missing_from_the_blob_store_fails_the_job_with_a_report(tmp_path, kind):
    ctx = _machine(tmp_path, "one", inline_input_bytes=16)
    try:
        service = JobService(ctx, Recorder())
        if kind == "upload":
            job = service.submit_upload("test-compute", "n.txt", b"1\n2\n", None, None).job
        else:
            job = service.submit_json("test-compute", b'{"values": [1, 2, 3, 4, 5]}', None).job
        ctx.files.delete(job.input_file)
        assert run_job(ctx, job.id, worker="w", requeue=Recorder().enqueue) == "failed"
        report = ctx.repo.get(job.id).report
        assert report["stage"] == "input" and "missing from the blob store" in report["message"]
    finally:
        ctx.close()
