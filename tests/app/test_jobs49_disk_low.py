"""Below the free-space floor (MIN_FREE_DISK_BYTES) the service starts no job and takes no submission: queued jobs
are held, not failed (nothing submitted is lost), and say "waiting: disk space low" until space returns; a submission
is a 503 problem naming disk space with Retry-After, as /readyz is 503 naming ``disk``."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs.errors import DISK_RETRY_AFTER_SECONDS
from tests.conftest import REPO, service_settings, wait_for

NO_DISK = 2 ** 62  # a floor no disk reaches


def _low(client: TestClient, floor: int) -> None:
    client.app.state.ctx.store.min_free_disk_bytes = floor


def _refused(response) -> None:
    assert response.status_code == 503, response.text
    assert response.headers["content-type"] == "application/problem+json"
    assert response.headers["retry-after"] == str(DISK_RETRY_AFTER_SECONDS)
    problem = response.json()
    assert problem["type"].endswith("/disk-space-low") and problem["title"] == "Disk space low"
    assert "disk" in problem["detail"] and "nothing was stored" in problem["detail"]


def test_a_submission_while_the_disk_is_low_is_a_503_naming_disk_space(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, min_free_disk_bytes=NO_DISK))) as client:
        assert client.get("/readyz").json()["checks"]["disk"] == "unavailable"
        _refused(client.post("/v1/test-compute/jobs", json={"values": [1.0]}))
        scan = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()
        _refused(client.post("/v1/tube/jobs", files={"file": ("scan.xyz", scan)}))
        assert client.get("/v1/jobs").json()["items"] == []  # nothing stored
        assert [p.name for p in (tmp_path / "artifacts").iterdir()] == [".readiness-probe"]  # no upload kept


@pytest.mark.parametrize("mode", ["thread", "process"])
def test_queued_jobs_wait_while_the_disk_is_low_and_run_once_it_has_room(tmp_path, mode):
    settings = service_settings(tmp_path, embedded_mode=mode, embedded_workers=1)
    with TestClient(create_app(settings)) as client:
        first = client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 1.5}).json()["id"]
        wait_for(client, first, statuses=("running",), timeout=60)
        waiting = [client.post("/v1/test-compute/jobs", json={"values": [float(i)]}).json()["id"] for i in (2, 3)]
        _low(client, NO_DISK)
        assert wait_for(client, first, timeout=60)["status"] == "succeeded"  # a running job is not stopped
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            views = [client.get(f"/v1/jobs/{job}").json() for job in waiting]
            if all(v["progress"]["message"] == "waiting: disk space low" for v in views):
                break
            time.sleep(0.1)
        time.sleep(2.0)  # held, not failed, however long it lasts
        for job in waiting:
            view = client.get(f"/v1/jobs/{job}").json()
            assert (view["status"], view["attempt"], view["progress"]["message"]) == \
                ("queued", 0, "waiting: disk space low")
            assert view["summary"].startswith("Waiting: disk space low")
        assert client.get("/readyz").json()["checks"]["disk"] == "unavailable"
        _low(client, 0)
        for job in waiting:
            done = wait_for(client, job, timeout=60)
            assert (done["status"], done["attempt"]) == ("succeeded", 1)
        assert client.get("/readyz").status_code == 200


def test_the_submit_routes_document_their_503(tmp_path):
    with TestClient(create_app(service_settings(tmp_path))) as client:
        paths = client.get("/openapi.json").json()["paths"]
    documented = paths["/v1/tube/jobs"]["post"]["responses"]["503"]
    assert "disk" in documented["description"] and "Retry-After" in documented["description"]


@pytest.mark.parametrize("upload", [False, True])
def test_a_repeated_request_whose_key_names_a_job_is_answered_with_it_while_the_disk_is_low(tmp_path, upload):
    """The client whose first answer was lost repeats its request with the same Idempotency-Key: its job exists, so
    nothing new is stored and the answer is that job, not a 503 saying nothing was stored; a new key is refused."""
    scan = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()

    def submit(client, key):
        headers = {"Idempotency-Key": key}
        if upload:
            return client.post("/v1/tube/jobs", files={"file": ("scan.xyz", scan)}, headers=headers)
        return client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 0.5}, headers=headers)

    with TestClient(create_app(service_settings(tmp_path))) as client:
        first = submit(client, "order-42")
        assert first.status_code == 202, first.text
        _low(client, NO_DISK)
        again = submit(client, "order-42")
        assert again.status_code == 200, again.text
        assert again.json()["id"] == first.json()["id"]
        _refused(submit(client, "order-43"))


def test_a_disk_whose_free_space_cannot_be_read_holds_jobs_until_it_can(tmp_path):
    """A stale network mount makes statvfs raise (ESTALE): the hold counts that look as held, the pool's threads
    live on, and the queued jobs run once the disk answers again."""
    import errno

    settings = service_settings(tmp_path, embedded_workers=1, min_free_disk_bytes=1)
    with TestClient(create_app(settings)) as client:
        store = client.app.state.ctx.store
        first = client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 1.5}).json()["id"]
        wait_for(client, first, statuses=("running",), timeout=60)
        queued = [client.post("/v1/test-compute/jobs", json={"values": [float(i)]}).json()["id"] for i in (2, 3)]

        def stale() -> None:
            raise OSError(errno.ESTALE, "Stale file handle")

        store.check_disk = stale
        try:
            assert wait_for(client, first, timeout=60)["status"] == "succeeded"
            time.sleep(2.0)
            assert [client.get(f"/v1/jobs/{job}").json()["status"] for job in queued] == ["queued", "queued"]
        finally:
            del store.check_disk  # the mount is back
        for job in queued:
            assert wait_for(client, job, timeout=60)["status"] == "succeeded"


@pytest.mark.parametrize("low", [False, True])
def test_a_repeated_request_stores_no_second_input(tmp_path, low):
    """A repeated upload or large JSON body (its Idempotency-Key names a stored job) is answered with that job and
    leaves no input file of its own behind, with the disk low or not: one input file per job."""
    scan = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()
    large = b'{"values": [' + b", ".join(b"1.0" for _ in range(2000)) + b"]}"
    with TestClient(create_app(service_settings(tmp_path, inline_input_bytes=1024))) as client:
        def submit(key):
            headers = {"Idempotency-Key": key}
            if key == "upload":
                return client.post("/v1/tube/jobs", files={"file": ("scan.xyz", scan)}, headers=headers)
            return client.post("/v1/test-compute/jobs", content=large,
                               headers={**headers, "content-type": "application/json"})

        first = {key: submit(key).json()["id"] for key in ("upload", "json")}
        if low:
            _low(client, NO_DISK)
        for key in ("upload", "json", "upload", "json"):
            again = submit(key)
            assert again.status_code == 200 and again.json()["id"] == first[key], again.text
        inputs = sorted(p.relative_to(tmp_path / "artifacts").parts[0]
                        for p in (tmp_path / "artifacts").rglob("*") if p.is_file() and "input" in p.parts)
        assert inputs == sorted(first.values())
