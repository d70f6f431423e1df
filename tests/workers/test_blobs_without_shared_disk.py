"""The API and two Celery workers on PostgreSQL + Redis, each with its own private DATA_DIR (and so its own
ARTIFACT_DIR), no folder shared: uploads are read by whichever worker claims the job, every artifact is
downloadable through the API, and no process left a blob on its own disk. Once with the PostgreSQL blob store
(the scaled default), once with S3 (moto's S3 server, started by the test)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import REPO, service_settings, wait_for
from tests.store.s3_server import moto_s3
from tests.workers.test_integration_celery import Worker


def _worker_env(pg_url: str, redis_url: str, data_dir: Path, blob_env: dict[str, str]) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("ARTIFACT_DIR", "BLOB_STORE", "S3_BUCKET", "S3_ENDPOINT_URL")}
    env.update(DATABASE_URL=pg_url, BROKER_URL=redis_url, DATA_DIR=str(data_dir), PLUGINS="tests.support.kinds",
               HEARTBEAT_SECONDS="0.3", LEASE_SECONDS="5", SWEEP_SECONDS="0.5", PROGRESS_WRITE_SECONDS="0",
               PYTHONPATH=str(REPO), **blob_env)
    return env


def _files_under(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.is_file() and p.suffix not in (".log", ".db", ".db-wal", ".db-shm")]


@pytest.mark.integration
@pytest.mark.parametrize("back_end", ["postgres", "s3"])
def test_api_and_two_workers_share_no_disk(back_end, pg_url, redis_url, tmp_path):
    folders = {name: tmp_path / name for name in ("api", "worker-1", "worker-2")}
    for folder in folders.values():
        folder.mkdir()
    with contextlib.ExitStack() as stack:
        blob_env = stack.enter_context(moto_s3()) if back_end == "s3" else {}
        settings = service_settings(folders["api"], database_url=pg_url, broker_url=redis_url, lease_seconds=5.0,
                                    inline_input_bytes=4096, **{k.lower(): v for k, v in blob_env.items()
                                                                if k.startswith(("BLOB", "S3"))})
        assert settings.resolved_blob_store == back_end  # postgres: the default on a PostgreSQL DATABASE_URL
        client = stack.enter_context(TestClient(create_app(settings)))  # migrates the database
        workers = Worker.several([(_worker_env(pg_url, redis_url, folders[name], blob_env), name,
                                   folders[name] / "worker.log") for name in ("worker-1", "worker-2")])
        for worker in workers:
            stack.callback(worker.stop)

        uploads = {}
        for n in range(6):  # uploads: stored by the API, read by the worker that claims the job
            values = [float(n), 2.5, -1.25 * n]
            content = "\n".join(map(repr, values)).encode()
            response = client.post("/v1/test-compute/jobs", files={"file": (f"values-{n}.txt", content, "text/plain")},
                                   data={"options": json.dumps({"seconds": 1.0})})
            assert response.status_code == 202, response.text
            uploads[response.json()["id"]] = (values, content)
        large = [i + 0.5 for i in range(2000)]  # more than INLINE_INPUT_BYTES: the request is stored as a blob
        response = client.post("/v1/test-compute/jobs", json={"values": large, "seconds": 0.5})
        assert response.status_code == 202, response.text
        uploads[response.json()["id"]] = (large, None)

        runners = set()
        for job_id, (values, content) in uploads.items():
            done = wait_for(client, job_id, timeout=120)
            assert done["status"] == "succeeded", done
            runners.add(done["attempts"][0]["worker"])
            assert client.get(f"/v1/jobs/{job_id}/result").json()["total"] == pytest.approx(sum(values))
            if content is not None:
                assert client.get(f"/v1/jobs/{job_id}/input/file").content == content
            else:
                assert json.loads(client.get(f"/v1/jobs/{job_id}/input").content)["values"] == large
            listed = {a["name"]: a for a in done["artifacts"]}
            assert set(listed) == {"values.txt", "summary.json"}
            for name, artifact in listed.items():  # every artifact, downloaded through the API
                got = client.get(f"/v1/jobs/{job_id}/artifacts/{name}")
                assert got.status_code == 200, got.text
                assert hashlib.sha256(got.content).hexdigest() == artifact["sha256"] == got.headers["x-content-sha256"]
                assert len(got.content) == artifact["size"]
            assert client.get(f"/v1/jobs/{job_id}/artifacts/values.txt").content == \
                "\n".join(map(repr, values)).encode()
        assert len(runners) == 2, f"both workers should have run jobs: {runners}"
        for name, folder in folders.items():  # nobody's disk holds a blob: nothing needed sharing
            assert _files_under(folder) == [], (name, _files_under(folder))


def test_the_compose_workers_mount_nothing_of_the_api():
    """docker-compose.yml: the workers share no volume with the API (blobs in PostgreSQL by default, or S3), so
    they run on any host that reaches PostgreSQL and Redis."""
    import yaml

    services = yaml.safe_load((REPO / "docker-compose.yml").read_text())["services"]
    assert "volumes" not in services["worker"]
    for name in ("api", "worker"):
        environment = services[name]["environment"]
        assert environment["BLOB_STORE"] == "${BLOB_STORE:-postgres}"
        assert {"S3_BUCKET", "S3_ENDPOINT_URL", "AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY"} <= set(environment)
