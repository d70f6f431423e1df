"""Real job processes of the embedded default killed around the spool: a process killed while its result's write
waits on the database (the SQLite write lock held by another process, long enough that it spools the result), and a
service started again on a folder where killed processes left spools. A killed process's interrupted puts leave
temporary files: the supervisor removes them. Readiness says 503 while the database takes no
write; every job ends exactly once (solved once: its spooled result is stored, not solved again) and no spool is
left behind."""

from __future__ import annotations

import os
import signal
import sqlite3
import time
import uuid
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.exc import OperationalError

from plantsolve.app.main import create_app
from plantsolve.jobs import spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from plantsolve.store.blobs import temporary_prefix
from tests.conftest import service_settings, wait_for
from tests.support.dispatch import Recorder

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def _settings(tmp_path):
    return service_settings(tmp_path, embedded_mode="process", embedded_workers=2, result_write_seconds=1.0,
                            database_wait_seconds=1.0, lease_seconds=6.0, progress_write_seconds=0.5)


def _ready(client, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while client.get("/readyz").status_code != 200:
        assert time.monotonic() < deadline, client.get("/readyz").json()
        time.sleep(0.05)


def _until(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.02)


def _runs(markers: Path) -> int:
    return len(list(markers.iterdir())) if markers.exists() else 0


def _files(root: Path) -> list[str]:
    """The blob folder's files but readiness's probe."""
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                  if p.is_file() and p.name != ".readiness-probe")


def test_a_job_process_killed_while_its_result_waits_on_the_database_is_solved_once(tmp_path):
    settings = _settings(tmp_path)
    markers = tmp_path / "runs"
    with TestClient(create_app(settings)) as client:
        _ready(client)
        dispatcher = client.app.state.dispatcher
        job_id = client.post("/v1/test-compute/jobs",
                             json={"values": [3.0, 4.0], "seconds": 1.0, "marker_dir": str(markers)}).json()["id"]
        wait_for(client, job_id, statuses=("running",), timeout=60)
        pid = dispatcher.running()[uuid.UUID(job_id)]
        holder = sqlite3.connect(settings.resolved_database_url.removeprefix("sqlite:///"), timeout=10)
        holder.execute("BEGIN EXCLUSIVE")  # another process holds the write lock: the commit cannot get through
        try:
            _until(lambda: client.get("/readyz").status_code == 503, 10, "readiness said 200 under the lock")
            assert client.get("/readyz").json()["checks"]["database"] == "unavailable"
            pending = settings.resolved_artifact_dir / spool.pending_path(uuid.UUID(job_id))
            _until(pending.exists, 60, "the result was not spooled")
            # what a put cut short by the kill leaves: its temporary file, never renamed into place
            interrupted = settings.resolved_artifact_dir / job_id / "a1" / f"{temporary_prefix(pid)}plot"
            interrupted.write_bytes(b"half a plot")
            try:
                os.kill(pid, signal.SIGKILL)  # mid-write: its re-queue waits on the lock
            except ProcessLookupError:  # its re-queue gave up first, and the process ended on that error
                pass
            _until(lambda: uuid.UUID(job_id) not in dispatcher.running(), 10, "the supervisor missed the death")
        finally:
            holder.rollback()
            holder.close()
        view = wait_for(client, job_id, timeout=60)
        _ready(client, 30)
    assert view["status"] == "succeeded", view
    assert _runs(markers) == 1  # the spooled result was stored, not solved again
    assert view["attempts"][-1]["outcome"] == "succeeded" and "computed by attempt 1" in view["attempts"][-1]["error"]
    assert not pending.exists() and not (settings.resolved_artifact_dir / spool.PREFIX).exists()
    assert [f for f in _files(settings.resolved_artifact_dir) if not f.startswith(job_id)] == []
    left = _files(settings.resolved_artifact_dir)
    assert [a["name"] for a in view["artifacts"]] and ".computed.json" not in str(left)
    assert not interrupted.exists() and ".tmp-" not in str(left)


def _away(*args, **kwargs):
    raise OperationalError("UPDATE jobs ...", {}, ConnectionError("server closed the connection"))


def test_a_service_started_on_spools_left_by_killed_processes_stores_the_waiting_one_and_sweeps_the_rest(
        tmp_path, monkeypatch):
    settings = _settings(tmp_path)
    markers = tmp_path / "runs"
    ctx = ServiceContext.create(settings, migrate=True)
    try:
        service = JobService(ctx, Recorder())
        body = f'{{"values": [6, 8], "marker_dir": "{markers}"}}'.encode()
        waiting, ended = (service.submit_json("test-compute", body, None).job.id for _ in range(2))
        with monkeypatch.context() as patch:  # both spooled their result, the database away at their commit
            patch.setattr(ctx.repo, "finish_success", _away)
            for job_id in (waiting, ended):
                assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "requeued"
            patch.setattr(spool, "remove", lambda *args, **kwargs: None)  # a process killed before its clean-up
            service.cancel(ended)
        assert _runs(markers) == 2 and spool.holder(ctx, ended) is ctx.files
    finally:
        ctx.close()
    with TestClient(create_app(settings)) as client:
        _ready(client)
        view = wait_for(client, str(waiting), timeout=60)
        _until(lambda: not (settings.resolved_artifact_dir / spool.pending_path(ended)).exists(), 30,
               "the start-up sweep left the cancelled job's spool")
        # the stored job's spool goes after its commit: waited for before the service stops (a stop in between
        # leaves it to the next start's sweep)
        _until(lambda: not (settings.resolved_artifact_dir / spool.PREFIX).exists(), 30,
               "the stored job's spool was not removed after its commit")
    assert view["status"] == "succeeded" and view["attempts"][-1]["outcome"] == "succeeded"
    assert _runs(markers) == 2  # each solved once
    assert not (settings.resolved_artifact_dir / spool.PREFIX).exists()
    assert [f for f in _files(settings.resolved_artifact_dir) if not f.startswith(str(waiting))] == []
