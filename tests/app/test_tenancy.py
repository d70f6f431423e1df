"""Tenancy and auth: each key sees only its own jobs, admins see all, auth comes before the body,
docs and readiness details are for authenticated callers, and a browser can log in to the dashboard."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for
from tests.support.login import log_in

PROBLEM = "application/problem+json"
A, B, ADMIN = ({"Authorization": "Bearer key-a"}, {"Authorization": "Bearer key-b"}, {"Authorization": "Bearer root"})


@pytest.fixture
def tenants(tmp_path):
    settings = service_settings(tmp_path, api_keys=["alice:key-a", "key-b"], admin_keys=["ops:root"])
    with TestClient(create_app(settings)) as client:
        yield client


def test_a_key_sees_only_its_own_jobs(tenants):
    client = tenants
    mine = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=A).json()
    wait_for(client, mine["id"], headers=A)
    theirs = client.post("/v1/test-compute/jobs", json={"values": [2.0]}, headers=B).json()
    wait_for(client, theirs["id"], headers=B)
    base = f"/v1/jobs/{mine['id']}"
    for path in (base, f"{base}/result", f"{base}/input", f"{base}/input/file", f"{base}/artifacts/values.txt",
                 f"{base}/events", f"/v1/test-compute/jobs/{mine['id']}/result"):
        assert client.get(path, headers=B).status_code == 404, path
        assert client.get(path, headers=A).status_code == 200, path
    assert client.post(f"{base}/cancel", headers=B).status_code == 404
    assert [j["id"] for j in client.get("/v1/jobs", headers=A).json()["items"]] == [mine["id"]]
    assert [j["id"] for j in client.get("/v1/jobs", headers=B).json()["items"]] == [theirs["id"]]
    assert {j["id"] for j in client.get("/v1/jobs", headers=ADMIN).json()["items"]} == {mine["id"], theirs["id"]}
    assert client.get(f"{base}/result", headers=ADMIN).status_code == 200


def test_the_same_idempotency_key_of_two_tenants_names_two_jobs(tenants):
    client = tenants
    a = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={**A, "Idempotency-Key": "order-7"})
    b = client.post("/v1/test-compute/jobs", json={"values": [9.0]}, headers={**B, "Idempotency-Key": "order-7"})
    assert a.status_code == b.status_code == 202 and a.json()["id"] != b.json()["id"]
    again = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={**A, "Idempotency-Key": "order-7"})
    assert again.status_code == 200 and again.json()["id"] == a.json()["id"]
    assert again.json()["idempotency_key"] == "order-7"


def test_auth_is_checked_before_the_body_is_read(tenants):
    client = tenants
    started = time.monotonic()
    response = client.post("/v1/test-compute/jobs", content=b"{" * 5_000_000, headers={"Content-Type": "application/json"})
    assert response.status_code == 401 and response.headers["www-authenticate"].startswith("Bearer")
    response = client.post("/v1/perfmap/jobs/00000000-0000-0000-0000-000000000000/query", content=b"[" * 1_000_000,
                           headers={"Content-Type": "application/json", "Authorization": "Bearer wrong"})
    assert response.status_code == 401 and response.json()["detail"] == "The API key is not valid."
    assert time.monotonic() - started < 5


def test_docs_and_readiness_details_need_a_key(tenants):
    client = tenants
    for path in ("/openapi.json", "/docs", "/redoc"):
        assert client.get(path).status_code == 401, path
        assert client.get(path, headers=A).status_code == 200, path
    assert client.get("/healthz").status_code == 200
    assert client.get("/readyz").json()["checks"] == {"database": "ok", "files": "ok", "disk": "ok", "jobs": "ok"}


def test_a_browser_logs_in_to_the_dashboard_with_a_cookie(tenants):
    client = tenants
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=A).json()
    first = client.get("/dashboard", follow_redirects=False)
    assert first.status_code == 303 and first.headers["location"] == "/dashboard/login"
    assert log_in(client, "nope").status_code == 401
    login = log_in(client, "key-a", follow_redirects=False)
    assert login.status_code == 303
    cookie = next(c for c in login.headers.get_list("set-cookie") if c.startswith("plantsolve_session="))
    assert "httponly" in cookie.lower() and "samesite=strict" in cookie.lower()
    page = client.get("/dashboard")
    assert page.status_code == 200 and job["id"] in page.text
    assert client.get(f"/v1/jobs/{job['id']}").status_code == 200  # reads work with the cookie
    # ... but a cookie never submits: a cross-site form cannot create jobs on the user's behalf
    assert client.post("/v1/test-compute/jobs", json={"values": [1.0]}).status_code == 401
    client.post("/dashboard/logout")
    assert client.get("/dashboard", follow_redirects=False).status_code == 303


def test_cors_is_off_by_default_and_follows_the_settings(tmp_path, tenants):
    preflight = {"Origin": "https://plant.example", "Access-Control-Request-Method": "POST"}
    assert "access-control-allow-origin" not in tenants.options("/v1/jobs", headers=preflight).headers
    with TestClient(create_app(service_settings(tmp_path / "cors", cors_origins=["https://plant.example"]))) as client:
        response = client.options("/v1/jobs", headers=preflight)
        assert response.headers["access-control-allow-origin"] == "https://plant.example"
        assert "access-control-allow-origin" not in client.options(
            "/v1/jobs", headers={**preflight, "Origin": "https://evil.example"}).headers


def _samples(text: str) -> dict[str, float]:
    return {line.rsplit(" ", 1)[0]: float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
            if line and not line.startswith("#")}


def test_metrics_show_a_tenant_its_own_counts_and_an_admin_all(tenants):
    client = tenants
    for values, headers in (([1.0], A), ([2.0], A), ([3.0], B)):
        wait_for(client, client.post("/v1/test-compute/jobs", json={"values": values}, headers=headers).json()["id"],
                 headers=headers)
    wait_for(client, client.post("/v1/test-fail/jobs", json={}, headers=B).json()["id"], headers=B)
    succeeded, failed = 'plantsolve_jobs{kind="test-compute",status="succeeded"}', 'plantsolve_jobs{kind="test-fail",status="failed"}'
    histogram = 'plantsolve_job_run_seconds_count{kind="test-compute",status="succeeded"}'
    seen = {name: _samples(client.get("/metrics", headers=headers).text) for name, headers in
            (("alice", A), ("b", B), ("admin", ADMIN))}
    assert (seen["alice"][succeeded], seen["alice"][failed], seen["alice"][histogram]) == (2, 0, 2)
    assert (seen["b"][succeeded], seen["b"][failed], seen["b"][histogram]) == (1, 1, 1)
    assert (seen["admin"][succeeded], seen["admin"][failed], seen["admin"][histogram]) == (3, 1, 3)
    assert 'plantsolve_job_run_seconds_count{kind="test-fail",status="failed"}' not in seen["alice"]
    assert client.get("/metrics").status_code == 401
