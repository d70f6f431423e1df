"""Readiness tells the truth, and a database that cannot take a write answers 503 in seconds: ``/readyz`` is 503
when the database cannot take a write, the blob store cannot take a file, or no job can start, naming only which
part (details in the log); a SQLite file locked by another process makes submit and cancel wait at most the
stated busy timeout; a PostgreSQL that does not answer is given up on after the connect timeout."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import threading
import time

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.exc import OperationalError

from plantsolve.app.main import create_app
from plantsolve.store.engine import Database
from tests.conftest import service_settings

WAIT = 1.0  # DATABASE_WAIT_SECONDS of these tests


@pytest.fixture
def client(tmp_path):
    # raise_server_exceptions=False: a 503 is answered by the outermost error middleware, which also re-raises
    with TestClient(create_app(service_settings(tmp_path, database_wait_seconds=WAIT)),
                    raise_server_exceptions=False) as client:
        yield client


def _hold_write_lock(db_path) -> subprocess.Popen:
    """Another process that holds the SQLite file's write lock (BEGIN IMMEDIATE) until killed."""
    code = ("import sqlite3, sys, time\n"
            f"c = sqlite3.connect({str(db_path)!r}, isolation_level=None)\n"
            "c.execute('BEGIN IMMEDIATE'); print('locked', flush=True); time.sleep(600)\n")
    holder = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "locked"
    return holder


def test_a_sqlite_file_locked_by_another_process_gives_503_within_the_busy_timeout(client, tmp_path):
    job_id = client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 30}).json()["id"]
    assert client.get("/readyz").status_code == 200
    holder = _hold_write_lock(tmp_path / "plantsolve.db")
    try:
        timings = {}
        for name, call in (("submit", lambda: client.post("/v1/test-compute/jobs", json={"values": [2.0]})),
                           ("keyed submit", lambda: client.post("/v1/test-compute/jobs", json={"values": [3.0]},
                                                                 headers={"Idempotency-Key": "k-1"})),
                           ("upload", lambda: client.post("/v1/test-compute/jobs",
                                                          files={"file": ("v.txt", b"1\n2\n", "text/plain")})),
                           ("cancel", lambda: client.post(f"/v1/jobs/{job_id}/cancel")),
                           ("readyz", lambda: client.get("/readyz"))):
            started = time.monotonic()
            response = call()
            timings[name] = time.monotonic() - started
            assert response.status_code == 503, (name, response.status_code, response.text)
        # two bounded waits at most (this process's write lock, then SQLite's busy timeout), plus the machine's slack
        assert max(timings.values()) < 2 * WAIT + 3, timings
        ready = client.get("/readyz").json()
        assert ready == {"status": "unavailable",
                         "checks": {"database": "unavailable", "files": "ok", "disk": "ok", "jobs": "ok"}}
    finally:
        holder.kill()
        holder.wait()
    assert client.get("/readyz").status_code == 200
    assert client.post(f"/v1/jobs/{job_id}/cancel").status_code == 200


def test_readiness_names_a_blob_store_that_cannot_take_a_file_and_tells_no_details(client, tmp_path, caplog):
    artifacts = tmp_path / "artifacts"
    assert client.get("/readyz").status_code == 200
    shutil.rmtree(artifacts)
    artifacts.write_text("not a folder")  # a disk that refuses: every file write fails
    ready = client.get("/readyz")
    assert ready.status_code == 503
    assert ready.json() == {"status": "unavailable",
                            "checks": {"database": "ok", "files": "unavailable", "disk": "ok", "jobs": "ok"}}
    assert str(tmp_path) not in ready.text
    assert any("not ready: files" in r.getMessage() and r.exc_info is None for r in caplog.records)


@pytest.mark.parametrize("margin, status", [(1, 503), (0, 200)])
def test_readiness_names_a_disk_below_the_free_space_floor(tmp_path, caplog, monkeypatch, margin, status):
    """MIN_FREE_DISK_BYTES above the free space of the disk that holds ARTIFACT_DIR and the SQLite file: 503 naming
    'disk', the folder and its free space in the log only; at it: ready. The free space is held still (another
    process writing a megabyte would move it between the measure and the check)."""
    import plantsolve.store.disk as disk

    free = shutil.disk_usage(tmp_path).free
    monkeypatch.setattr(disk, "free_bytes", lambda folder: free)
    floor = free + margin
    with TestClient(create_app(service_settings(tmp_path, min_free_disk_bytes=floor)),
                    raise_server_exceptions=False) as client:
        ready = client.get("/readyz")
    assert ready.status_code == status
    if status == 200:
        return
    assert ready.json() == {"status": "unavailable",
                            "checks": {"database": "ok", "files": "ok", "disk": "unavailable", "jobs": "ok"}}
    assert str(tmp_path) not in ready.text
    said = [r.getMessage() for r in caplog.records if "not ready: disk" in r.getMessage()]
    # one disk holds both folders: named once, by the first role
    assert said and "ARTIFACT_DIR" in said[-1] and "MiB free" in said[-1] and "database (" not in said[-1], said


def test_a_floor_of_zero_checks_nothing(tmp_path):
    from plantsolve.store.disk import DiskLow, check_free_space

    check_free_space({"ARTIFACT_DIR": tmp_path / "not" / "made"}, 0)
    with pytest.raises(DiskLow, match=r"ARTIFACT_DIR .*not/made.*MiB free"):
        check_free_space({"ARTIFACT_DIR": tmp_path / "not" / "made"}, shutil.disk_usage(tmp_path).free + 2**30)


def _silent_server() -> tuple[socket.socket, int]:
    """A listener that accepts connections and never answers: a database whose link holds connections."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(64)
    held = []
    threading.Thread(target=lambda: [held.append(server.accept()) for _ in range(64)], daemon=True).start()
    return server, server.getsockname()[1]


def test_a_postgresql_that_never_answers_is_given_up_on_within_the_connect_timeout():
    server, port = _silent_server()
    try:
        db = Database(f"postgresql+psycopg://postgres@127.0.0.1:{port}/plantsolve", wait=WAIT)
        started = time.monotonic()
        with pytest.raises(OperationalError):
            db.ping()
        assert time.monotonic() - started < WAIT + 3
    finally:
        server.close()


@pytest.mark.usefixtures("pg_url")
def test_a_postgresql_statement_is_bounded_by_the_statement_timeout(pg_url):
    db = Database(pg_url, wait=WAIT, statement=1.0)
    started = time.monotonic()
    with pytest.raises(OperationalError, match="statement timeout"):
        with db.engine.connect() as connection:
            connection.exec_driver_sql("SELECT pg_sleep(30)")
    assert time.monotonic() - started < 4
    db.ping()  # the same settings answer a plain statement
