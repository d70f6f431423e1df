"""HTTP round trips on the embedded default: submit, poll, result, artifacts, list, cancel,
idempotency, auth, and every error as problem+json."""

from __future__ import annotations

import hashlib
import json

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for

PROBLEM = "application/problem+json"


def test_submit_poll_result_and_artifacts(client):
    response = client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]})
    assert response.status_code == 202
    job = response.json()
    assert response.headers["location"] == f"/v1/jobs/{job['id']}"
    assert job["status"] in ("queued", "running", "succeeded")
    done = wait_for(client, job["id"])
    assert done["status"] == "succeeded"
    assert done["progress"]["fraction"] == 1.0
    assert done["timings"]["run_seconds"] >= 0
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    assert result["total"] == 7.0 and result["norm"] == 5.0
    names = {a["name"]: a for a in done["artifacts"]}
    assert set(names) == {"values.txt", "summary.json"}
    values = client.get(names["values.txt"]["url"])
    assert values.status_code == 200 and values.headers["content-type"].startswith("text/plain")
    assert values.content == b"3.0\n4.0"
    assert names["values.txt"]["sha256"] == hashlib.sha256(b"3.0\n4.0").hexdigest()
    assert client.get(f"/v1/jobs/{job['id']}/input").json() == {"values": [3.0, 4.0]}


def test_multipart_upload_with_options(client):
    files = {"file": ("numbers.txt", b"1\n2\n2.5\n", "text/plain")}
    response = client.post("/v1/test-compute/jobs", files=files, data={"options": json.dumps({"seconds": 0})})
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"])
    assert client.get(f"/v1/jobs/{done['id']}/result").json()["total"] == 5.5
    # the input: the file's name, the multipart options and a link to the file, which is the bytes as sent
    submitted = client.get(f"/v1/jobs/{done['id']}/input").json()
    assert submitted == {"filename": "numbers.txt", "options": {"seconds": 0}, "size": 8,
                         "file": f"/v1/jobs/{done['id']}/input/file"}
    assert client.get(submitted["file"]).content == b"1\n2\n2.5\n"


def test_list_filters_and_cursor_pagination(client):
    ids = [client.post("/v1/test-compute/jobs", json={"values": [float(i)]}).json()["id"] for i in range(5)]
    client.post("/v1/test-fail/jobs", json={})
    seen, cursor = [], None
    while True:
        page = client.get("/v1/jobs", params={"kind": "test-compute", "limit": 2, **({"cursor": cursor} if cursor else {})}).json()
        seen += [item["id"] for item in page["items"]]
        cursor = page["next_cursor"]
        if cursor is None:
            break
    assert seen == list(reversed(ids))  # newest first, every job exactly once
    for job_id in ids:
        wait_for(client, job_id)
    succeeded = client.get("/v1/jobs", params={"status": "succeeded", "kind": "test-compute"}).json()["items"]
    assert {item["id"] for item in succeeded} == set(ids)
    bad = client.get("/v1/jobs", params={"cursor": "not-a-cursor"})
    assert bad.status_code == 422 and bad.json()["errors"][0]["loc"] == ["query", "cursor"]


def test_idempotency_same_body_same_job_other_body_422(client):
    headers = {"Idempotency-Key": "order-42"}
    first = client.post("/v1/test-compute/jobs", json={"values": [1.0, 2.0]}, headers=headers)
    # Same JSON with another key order and spacing: the same body.
    again = client.post(
        "/v1/test-compute/jobs", content=b'{ "values" : [1.0, 2.0] }', headers={**headers, "Content-Type": "application/json"}
    )
    assert first.status_code == 202 and again.status_code == 200
    assert again.json()["id"] == first.json()["id"]
    other = client.post("/v1/test-compute/jobs", json={"values": [9.0]}, headers=headers)
    assert other.status_code == 422 and other.headers["content-type"] == PROBLEM
    assert other.json()["errors"][0]["loc"] == ["header", "Idempotency-Key"]
    assert len(client.get("/v1/jobs").json()["items"]) == 1


def test_cancel_queued_and_running_and_409_when_finished(client):
    running = client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 30}).json()
    wait_for(client, running["id"], statuses=("running",))
    cancelled = client.post(f"/v1/jobs/{running['id']}/cancel")
    assert cancelled.status_code == 200 and cancelled.json()["status"] == "cancelled"
    # The solver stops at its next progress report and cannot overwrite the cancellation.
    finished = client.post("/v1/test-compute/jobs", json={"values": [2.0]}).json()
    wait_for(client, finished["id"])
    assert client.get(f"/v1/jobs/{running['id']}").json()["status"] == "cancelled"
    again = client.post(f"/v1/jobs/{finished['id']}/cancel")
    assert again.status_code == 409 and again.headers["content-type"] == PROBLEM
    result = client.get(f"/v1/jobs/{running['id']}/result")
    assert result.status_code == 409 and result.json()["extra"]["status"] == "cancelled"


def test_cancel_queued_job_never_runs(tmp_path):
    app = create_app(service_settings(tmp_path), run_jobs=False)
    with TestClient(app) as client:
        job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
        assert client.post(f"/v1/jobs/{job['id']}/cancel").json()["status"] == "cancelled"
        from plantsolve.jobs.runner import run_job

        assert run_job(app.state.ctx, __import__("uuid").UUID(job["id"]), worker="t", requeue=lambda *a: None) == "skipped"
        assert client.get(f"/v1/jobs/{job['id']}").json()["status"] == "cancelled"


@pytest.mark.parametrize(
    ("body", "loc"),
    [
        ({"values": []}, ["values"]),
        ({"values": [1.0, "x"]}, ["values", 1]),
        ({"values": [1.0], "unknown": 1}, ["unknown"]),
        ({"values": [1.0, 666.0]}, ["values", 1]),  # the solver's own check_input
        ({"seconds": 1}, ["values"]),
    ],
)
def test_invalid_json_fields_are_422_with_their_path(client, body, loc):
    response = client.post("/v1/test-compute/jobs", json=body)
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    problem = response.json()
    assert problem["status"] == 422 and problem["title"]
    assert loc in [error["loc"] for error in problem["errors"]]


def test_nan_and_malformed_json_are_422(client):
    nan = client.post("/v1/test-compute/jobs", content=b'{"values": [NaN]}', headers={"Content-Type": "application/json"})
    assert nan.status_code == 422 and nan.json()["errors"][0]["loc"] == ["values", 0]
    broken = client.post("/v1/test-compute/jobs", content=b'{"values": [1,', headers={"Content-Type": "application/json"})
    assert broken.status_code == 422 and broken.headers["content-type"] == PROBLEM


def test_404_415_and_upload_errors(client):
    missing = client.get("/v1/jobs/00000000-0000-0000-0000-000000000000")
    assert missing.status_code == 404 and missing.headers["content-type"] == PROBLEM
    assert client.get("/v1/jobs/00000000-0000-0000-0000-000000000000/artifacts/x.png").status_code == 404
    assert client.post("/v1/no-such-solver/jobs", json={}).status_code == 404
    text = client.post("/v1/test-compute/jobs", content=b"1 2 3", headers={"Content-Type": "text/plain"})
    assert text.status_code == 415 and text.headers["content-type"] == PROBLEM
    wrong_type = client.post("/v1/test-compute/jobs", files={"file": ("scan.exe", b"MZ", "application/octet-stream")})
    assert wrong_type.status_code == 415
    unreadable = client.post("/v1/test-compute/jobs", files={"file": ("n.txt", b"1\nabc\n", "text/plain")})
    assert unreadable.status_code == 422 and unreadable.json()["errors"][0]["loc"] == ["file"]
    bad_options = client.post("/v1/test-compute/jobs", files={"file": ("n.txt", b"1\n", "text/plain")}, data={"options": "{oops"})
    assert bad_options.status_code == 422 and bad_options.json()["errors"][0]["loc"] == ["options"]
    no_file = client.post("/v1/test-compute/jobs", data={"options": "{}"}, files={"other": ("a.txt", b"1", "text/plain")})
    assert no_file.status_code == 422 and no_file.json()["errors"][0]["loc"] == ["file"]


def test_413_before_the_body_is_read(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, max_body_bytes=1000))) as client:
        big = {"values": [1.0] * 500}
        response = client.post("/v1/test-compute/jobs", json=big)
        assert response.status_code == 413 and response.headers["content-type"] == PROBLEM

        def chunks():  # no Content-Length: counted while it streams
            for _ in range(10):
                yield b" " * 500

        streamed = client.post("/v1/test-compute/jobs", content=chunks(), headers={"Content-Type": "application/json"})
        assert streamed.status_code == 413
        assert client.post("/v1/test-compute/jobs", json={"values": [1.0]}).status_code == 202


def test_large_json_input_is_stored_as_a_file(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, inline_input_bytes=100))) as client:
        values = [float(i) + 0.5 for i in range(200)]
        job = client.post("/v1/test-compute/jobs", json={"values": values}).json()
        wait_for(client, job["id"])
        assert client.get(f"/v1/jobs/{job['id']}/result").json()["total"] == sum(values)
        assert client.get(f"/v1/jobs/{job['id']}/input").json() == {"values": values}


def test_api_keys(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["k1", "k2"]))) as client:
        assert client.get("/healthz").status_code == 200  # health stays open for probes
        anonymous = client.get("/v1/jobs")
        assert anonymous.status_code == 401 and anonymous.headers["content-type"] == PROBLEM
        assert anonymous.headers["www-authenticate"].startswith("Bearer")
        assert client.get("/v1/jobs", headers={"Authorization": "Bearer nope"}).status_code == 401
        assert client.post("/v1/test-compute/jobs", json={"values": [1.0]}).status_code == 401
        ok = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={"Authorization": "Bearer k2"})
        assert ok.status_code == 202
        assert client.get("/dashboard", follow_redirects=False).status_code == 303  # to the login form
        assert client.get("/dashboard", headers={"Authorization": "Bearer k1"}).status_code == 200


def test_no_auth_by_default_and_health(client):
    assert client.get("/v1/jobs").status_code == 200
    ready = client.get("/readyz")
    assert ready.status_code == 200 and ready.json()["checks"] == {"database": "ok", "files": "ok", "disk": "ok", "jobs": "ok"}


def test_openapi_declares_kinds_and_errors(client):
    spec = client.get("/openapi.json").json()
    submit = spec["paths"]["/v1/test-compute/jobs"]["post"]
    content = submit["requestBody"]["content"]
    assert content["application/json"]["schema"]["$ref"] == "#/components/schemas/ComputeRequest"
    assert "multipart/form-data" in content
    assert {"202", "200", "401", "413", "415", "422"} <= set(submit["responses"])
    assert "ComputeResult" in spec["components"]["schemas"] and "Problem" in spec["components"]["schemas"]
    assert {"404", "409"} <= set(spec["paths"]["/v1/jobs/{job_id}/cancel"]["post"]["responses"])


def test_failed_job_has_report_and_result_is_409(client):
    job = client.post("/v1/test-fail/jobs", json={"message": "cannot fit"}).json()
    done = wait_for(client, job["id"])
    assert done["status"] == "failed" and done["attempt"] == 1  # a SolverError is not retried
    assert done["report"]["stage"] == "fit" and done["report"]["message"] == "cannot fit"
    assert done["report"]["details"] == {"residual": 1.5}
    response = client.get(f"/v1/jobs/{job['id']}/result")
    assert response.status_code == 409 and response.json()["extra"]["report"]["stage"] == "fit"


def test_dashboard_lists_jobs(client):
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
    wait_for(client, job["id"])
    page = client.get("/dashboard")
    assert page.status_code == 200 and job["id"] in page.text and "succeeded" in page.text


def test_empty_or_control_char_idempotency_key_is_422(client):
    for key in ("", " leading-space", "tab\there"):
        response = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={"Idempotency-Key": key})
        assert response.status_code == 422, (key, response.text)
        assert response.json()["errors"][0]["loc"] == ["header", "Idempotency-Key"]


def test_result_with_non_finite_numbers_fails_with_a_report(client):
    job = client.post("/v1/test-compute/jobs", json={"values": [1e308, 1e308]}).json()  # the sum overflows
    done = wait_for(client, job["id"])
    assert done["status"] == "failed" and done["attempt"] == 1
    assert done["report"]["stage"] == "result" and "/total" in done["report"]["details"]["paths"]
