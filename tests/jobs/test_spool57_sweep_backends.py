"""The start-up sweep lists the spool in every blob store (``keys`` of a prefix: a folder, the ``blobs`` table, an S3
bucket) and in this machine's folder beside another back-end; it removes the spools of ended jobs (with the
artifacts they name) and keeps those whose job waits for them."""

from __future__ import annotations

import uuid

import pytest

from plantsolve.jobs import spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.service import JobService
from tests.conftest import service_settings
from tests.store.s3_server import moto_s3
from tests.support.dispatch import Recorder


def _ended_and_waiting(ctx, store) -> tuple[uuid.UUID, uuid.UUID]:
    """Two jobs with a spool in ``store`` (written as an attempt writes it): one cancelled since, one queued."""
    service = JobService(ctx, Recorder())
    ended, waiting = (service.submit_json("test-compute", b'{"values": [1]}', None).job.id for _ in range(2))
    for job_id in (ended, waiting):
        assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
        stored = ctx.files.put(f"{job_id}/a1/values.txt", b"1.0")
        store.put(spool.pending_artifact_key(job_id, "plot.png"), b"png")
        store.put(spool.pending_path(job_id), (
            '{"attempt": 1, "spooled_by": 1, "unstored": [{"name": "plot.png", "media_type": "image/png"}], '
            f'"artifacts": [{{"name": "values.txt", "path": "{stored.key}"}}]}}').encode())
        assert ctx.repo.requeue(job_id, 1, report=None)
    assert service.cancel(ended).status == "cancelled"
    # the cancel was made by a process that removed nothing (another machine's API, or one killed right after)
    return ended, waiting


def _sweep_keeps_only_the_waiting(ctx, store, monkeypatch) -> None:
    monkeypatch.setattr(spool, "remove", lambda *args, **kwargs: None)
    ended, waiting = _ended_and_waiting(ctx, store)
    monkeypatch.undo()
    assert sorted(store.keys(spool.PREFIX)) == sorted(
        [spool.pending_path(j) for j in (ended, waiting)] + [spool.pending_artifact_key(j, "plot.png")
                                                            for j in (ended, waiting)])
    assert spool.sweep(ctx) == 3  # the ended job's result, its waiting artifact and the artifact it had stored
    assert sorted(store.keys(spool.PREFIX)) == sorted([spool.pending_path(waiting),
                                                       spool.pending_artifact_key(waiting, "plot.png")])
    assert not ctx.files.exists(f"{ended}/a1/values.txt") and ctx.files.exists(f"{waiting}/a1/values.txt")
    assert spool.sweep(ctx) == 0


def test_the_sweep_of_the_database_back_end_and_of_this_machines_folder(tmp_path, monkeypatch):
    ctx = ServiceContext.create(service_settings(tmp_path, blob_store="postgres"), migrate=True)
    try:
        assert ctx.spool is not ctx.files
        _sweep_keeps_only_the_waiting(ctx, ctx.files, monkeypatch)
        _sweep_keeps_only_the_waiting(ctx, ctx.spool, monkeypatch)
    finally:
        ctx.close()


def test_the_sweep_of_an_s3_bucket(tmp_path, monkeypatch):
    with moto_s3() as env:
        ctx = ServiceContext.create(service_settings(tmp_path, blob_store="s3", s3_bucket=env["S3_BUCKET"],
                                                     s3_endpoint_url=env["S3_ENDPOINT_URL"]), migrate=True)
        try:
            _sweep_keeps_only_the_waiting(ctx, ctx.files, monkeypatch)
        finally:
            ctx.close()


@pytest.mark.parametrize("prefix", ["pending/", "pending/x/"])
def test_a_local_listing_of_a_folder_that_is_not_there_is_empty(ctx, prefix):
    assert list(ctx.files.keys(prefix)) == []
