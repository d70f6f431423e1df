"""HTTP details: unknown kinds, HEAD on artifacts, the submitted input with its options, request ids,
structured job logs, and Prometheus metrics computed from the database."""

from __future__ import annotations

import json
import logging
import re
import uuid

from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.workers.logs import JsonFormatter
from tests.conftest import service_settings, wait_for


def test_an_unknown_kind_is_a_404_listing_the_kinds(client):
    for method, path in (("POST", "/v1/pipes/jobs"), ("GET", f"/v1/pipes/jobs/{uuid.uuid4()}/result"),
                         ("POST", f"/v1/pipes/jobs/{uuid.uuid4()}/query")):
        response = client.request(method, path, json={})
        assert response.status_code == 404 and response.headers["content-type"] == "application/problem+json"
        problem = response.json()
        assert "'pipes'" in problem["detail"] and "tube" in problem["detail"] and "perfmap" in problem["detail"]
        assert {"alignment", "tube", "perfmap", "polyhedra", "flowmeter"} <= set(problem["extra"]["kinds"])
    # a known kind keeps its routes and its method answers
    assert client.get("/v1/tube/jobs").status_code == 405
    plain = client.get(f"/v1/tube/jobs/{uuid.uuid4()}/nothing")
    assert plain.status_code == 404 and "kinds" not in (plain.json().get("extra") or {})
    assert client.post("/v1/test-compute/jobs", json={"values": [1.0]}).status_code == 202


def test_head_on_an_artifact_gives_its_headers_without_a_body(client):
    job = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]}).json()["id"])
    info = {a["name"]: a for a in job["artifacts"]}["values.txt"]
    head = client.head(info["url"])
    assert head.status_code == 200 and head.content == b""
    assert int(head.headers["content-length"]) == info["size"] == len(b"3.0\n4.0")
    assert head.headers["content-type"].startswith("text/plain")
    assert head.headers["x-content-sha256"] == info["sha256"]
    get = client.get(info["url"])
    assert get.headers["x-content-sha256"] == info["sha256"] and get.content == b"3.0\n4.0"
    missing = client.head(f"/v1/jobs/{job['id']}/artifacts/nothing.png")
    assert missing.status_code == 404 and missing.content == b""


def test_request_ids_are_answered_and_logged(client, caplog):
    caplog.set_level(logging.INFO, logger="plantsolve")
    mine = str(uuid.uuid4())
    response = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={"X-Request-ID": mine})
    assert response.headers["x-request-id"] == mine
    assert re.fullmatch(r"[0-9a-f]{32}", client.get("/healthz").headers["x-request-id"])  # made up when not sent
    submitted = [r for r in caplog.records if getattr(r, "job_id", None) == response.json()["id"]
                 and r.name == "plantsolve.api"]
    assert submitted and submitted[0].request_id == mine


def test_refusals_carry_a_request_id_too(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["k"]))) as client:
        refused = client.get("/v1/jobs")
        assert refused.status_code == 401 and refused.headers["x-request-id"]


def test_each_attempt_is_logged_as_json_with_id_kind_attempt_duration_outcome(client, caplog):
    caplog.set_level(logging.INFO, logger="plantsolve")
    ok = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 0.2}).json()["id"])
    failed = wait_for(client, client.post("/v1/test-fail/jobs", json={"message": "no fit"}).json()["id"])
    ends = {r.job_id: r for r in caplog.records if r.name == "plantsolve.runner" and getattr(r, "outcome", "") != "started"
            and getattr(r, "job_id", None)}
    for job, outcome, level in ((ok, "succeeded", "INFO"), (failed, "failed", "WARNING")):
        line = json.loads(JsonFormatter().format(ends[job["id"]]))
        assert line["job_id"] == job["id"] and line["kind"] == job["kind"] and line["attempt"] == 1
        assert line["outcome"] == outcome and line["level"] == level and line["worker"]
        assert line["duration_seconds"] >= (0.2 if outcome == "succeeded" else 0.0)
        assert line["logger"] == "plantsolve.runner" and line["time"].endswith("+00:00")
    started = [r for r in caplog.records if getattr(r, "outcome", "") == "started" and r.job_id == ok["id"]]
    assert len(started) == 1 and started[0].attempt == 1


def _samples(text: str) -> dict[str, float]:
    return {line.rsplit(" ", 1)[0]: float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
            if line and not line.startswith("#")}


def test_metrics_come_from_the_database(tmp_path):
    settings = service_settings(tmp_path)
    with TestClient(create_app(settings)) as client:
        for values in ([1.0], [2.0]):
            wait_for(client, client.post("/v1/test-compute/jobs", json={"values": values, "seconds": 0.1}).json()["id"])
        wait_for(client, client.post("/v1/test-fail/jobs", json={}).json()["id"])
    # another process on the same database (no jobs run in it) reports the same totals, plus its queue
    with TestClient(create_app(settings, run_jobs=False)) as other:
        for _ in range(3):
            other.post("/v1/test-compute/jobs", json={"values": [1.0]})
        response = other.get("/metrics")
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/plain")
    samples = _samples(response.text)
    assert samples['plantsolve_jobs{kind="test-compute",status="succeeded"}'] == 2
    assert samples['plantsolve_jobs{kind="test-fail",status="failed"}'] == 1
    assert samples['plantsolve_jobs{kind="test-compute",status="queued"}'] == 3
    assert samples['plantsolve_queue_depth{kind="test-compute"}'] == 3
    assert samples['plantsolve_queue_depth{kind="tube"}'] == 0
    assert samples['plantsolve_queue_oldest_seconds{kind="test-compute"}'] >= 0
    count = samples['plantsolve_job_run_seconds_count{kind="test-compute",status="succeeded"}']
    assert count == 2 == samples['plantsolve_job_run_seconds_bucket{kind="test-compute",le="+Inf",status="succeeded"}']
    assert samples['plantsolve_job_run_seconds_bucket{kind="test-compute",le="0.1",status="succeeded"}'] == 0  # slept 0.1 s
    assert samples['plantsolve_job_run_seconds_sum{kind="test-compute",status="succeeded"}'] >= 0.2


def test_metrics_need_a_key_when_keys_are_set(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["k"]), run_jobs=False)) as client:
        assert client.get("/metrics").status_code == 401
        assert client.get("/metrics", headers={"Authorization": "Bearer k"}).status_code == 200
