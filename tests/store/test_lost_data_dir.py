"""A data directory removed under a running embedded service (``rm -rf var``, a temporary-file cleaner, a volume
that went away): the SQLite file the service opened has no name any more. Before, submissions were answered 202 and
written into that nameless file (gone with the process: lost), new connections made a new, empty database at the path
(every read a 503 'no such table'), ``/readyz`` said ok, and the webhook loop logged a traceback every second."""

from __future__ import annotations

import logging
import shutil
import time

from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.store.engine import Database
from tests.conftest import service_settings, wait_for

PROBLEM = "application/problem+json"


def test_a_removed_database_file_makes_writes_and_readiness_503_and_no_empty_database_is_made(tmp_path, caplog):
    data = tmp_path / "var"
    settings = service_settings(data, database_wait_seconds=0.5)
    with TestClient(create_app(settings)) as client:
        first = client.post("/v1/test-compute/jobs", json={"values": [3, 4]}).json()["id"]
        assert wait_for(client, first)["status"] == "succeeded"
        assert client.get("/readyz").status_code == 200
        shutil.rmtree(data)
        with caplog.at_level(logging.INFO):
            submitted = client.post("/v1/test-compute/jobs", json={"values": [1]})
            assert submitted.status_code == 503 and submitted.headers["content-type"] == PROBLEM
            ready = client.get("/readyz")
            assert ready.status_code == 503 and ready.json()["checks"]["database"] == "unavailable"
            time.sleep(2.5)  # a few webhook rounds (one a second)
        assert not (data / "plantsolve.db").exists()  # no new, empty database at the path
        assert "removed or replaced" in caplog.text
        rounds = [r for r in caplog.records if r.name == "plantsolve.webhooks"]
        assert len(rounds) <= 1 and not any(r.exc_info for r in rounds)


def test_a_database_file_replaced_under_the_service_is_not_written_until_a_restart(tmp_path):
    data = tmp_path / "var"
    settings = service_settings(data, database_wait_seconds=0.5)
    with TestClient(create_app(settings)) as client:
        assert client.post("/v1/test-compute/jobs", json={"values": [1]}).status_code == 202
        copy = tmp_path / "copy.db"
        shutil.copy(data / "plantsolve.db", copy)
        (data / "plantsolve.db").unlink()
        shutil.move(copy, data / "plantsolve.db")  # restored from a copy while the service runs: another file
        assert client.post("/v1/test-compute/jobs", json={"values": [2]}).status_code == 503
    with TestClient(create_app(settings)) as client:  # a restart opens the file now at the path
        assert client.get("/readyz").status_code == 200
        assert client.post("/v1/test-compute/jobs", json={"values": [3]}).status_code == 202


def test_a_uri_filename_database_url_watches_its_file(tmp_path):
    """'sqlite:///file:/…/u.db?uri=true' watched a file named 'file:/…' in the working folder: none was ever found,
    so a removed database was written on without a word."""
    folder = tmp_path
    database = Database(f"sqlite:///file:{folder}/u.db?uri=true")
    assert database.file is not None and database.file.path == (folder / "u.db").resolve()
