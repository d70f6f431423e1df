"""The dashboard's submissions while the disk is low (the submit form, JSON or upload, and a job's Re-run) answer the
503 page naming disk space with ``Retry-After``, as ``POST /v1/<kind>/jobs`` does: before, the page came without it."""

from __future__ import annotations

import json

from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs.errors import DISK_RETRY_AFTER_SECONDS
from tests.conftest import service_settings, wait_for

NO_DISK = 2 ** 62  # a floor no disk reaches


def _refused(response) -> None:
    assert response.status_code == 503, response.text
    assert response.headers["retry-after"] == str(DISK_RETRY_AFTER_SECONDS)
    assert "Disk space low" in response.text and "text/html" in response.headers["content-type"]


def test_dashboard_submissions_while_the_disk_is_low_say_when_to_retry(tmp_path):
    with TestClient(create_app(service_settings(tmp_path))) as client:
        earlier = client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]}).json()["id"]
        assert wait_for(client, earlier)["status"] == "succeeded"
        client.app.state.ctx.store.min_free_disk_bytes = NO_DISK
        body = json.dumps({"values": [1.0]})
        _refused(client.post("/dashboard/submit/test-compute", data={"source": "json", "body": body},
                             files={"file": ("", b"")}))
        _refused(client.post("/dashboard/submit/tube", data={"source": "upload", "options": "{}"},
                             files={"file": ("scan.xyz", b"0 0 0\n1 0 0\n0 1 0\n", "text/plain")}))
        _refused(client.post(f"/dashboard/jobs/{earlier}/rerun", data={}, follow_redirects=False))
        assert [job["id"] for job in client.get("/v1/jobs").json()["items"]] == [earlier]  # nothing stored
        client.app.state.ctx.store.min_free_disk_bytes = 0
        taken = client.post("/dashboard/submit/test-compute", data={"source": "json", "body": body},
                            files={"file": ("", b"")}, follow_redirects=False)
        assert taken.status_code == 303 and "retry-after" not in taken.headers
