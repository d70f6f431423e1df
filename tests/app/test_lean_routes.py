"""The lean path of POST /v1/<kind>/jobs (JSON) and GET /v1/jobs/{id} answers as the routes do, byte for byte.

A request with a query string goes to the routes, so each lean answer can be compared with the routes' answer to the
same request: here the routes take the query parameter ``via`` (elsewhere one a route does not take is a 422)."""

from __future__ import annotations

import uuid

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.routed import routed_by

ALICE = {"Authorization": "Bearer key-a"}
BOB = {"Authorization": "Bearer key-b"}
ROUTED = "?via=routes"  # any query string: the request goes through the router


@pytest.fixture(params=["embedded", pytest.param("scaled", marks=pytest.mark.integration)])
def client(request, tmp_path):
    """Embedded (SQLite: group commit, reads on the loop) and scaled (PostgreSQL and Redis: the submission's write
    and message and the status read awaited on the loop)."""
    # (a loaded machine's PostgreSQL may take longer than the default 3 s wait: these tests are about the answers'
    # form, not about the wait, which tests of their own bound)
    scaled = {"database_url": request.getfixturevalue("pg_url"), "broker_url": request.getfixturevalue("redis_url"),
              "database_wait_seconds": 15.0} if request.param == "scaled" else {}
    settings = service_settings(tmp_path, api_keys=["alice:key-a", "bob:key-b"], **scaled)
    with routed_by("via"):
        app = create_app(settings, run_jobs=False)
    with TestClient(app) as client:
        assert client.app.state.jobs.stores_on_loop == client.app.state.jobs.reads_on_loop == bool(scaled)
        yield client


def _same_answer(lean, routed) -> None:
    assert lean.status_code == routed.status_code
    assert lean.content == routed.content
    ignored = {"x-request-id", "date"}
    assert {k: v for k, v in lean.headers.items() if k not in ignored} == \
        {k: v for k, v in routed.headers.items() if k not in ignored}


def test_submit_and_status_answer_as_the_routes_do(client):
    key = f"same-{uuid.uuid4()}"  # the scaled database lives as long as the test session
    lean = client.post("/v1/test-compute/jobs", json={"values": [1.0, 2.0]},
                       headers={**ALICE, "Idempotency-Key": key})
    assert lean.status_code == 202 and lean.headers["location"] == f"/v1/jobs/{lean.json()['id']}"
    # the same key and body again: 200 with the stored job, from either path
    again = client.post("/v1/test-compute/jobs", json={"values": [1.0, 2.0]}, headers={**ALICE, "Idempotency-Key": key})
    routed = client.post(f"/v1/test-compute/jobs{ROUTED}", json={"values": [1.0, 2.0]},
                         headers={**ALICE, "Idempotency-Key": key})
    assert again.status_code == 200 and again.json()["id"] == lean.json()["id"]
    _same_answer(again, routed)
    # the view made from the submitted columns is the view read back from the database
    assert lean.json() == again.json()

    job = lean.json()["id"]
    _same_answer(client.get(f"/v1/jobs/{job}", headers=ALICE), client.get(f"/v1/jobs/{job}{ROUTED}", headers=ALICE))
    # another tenant's job, and no job at all: the same 404 problem
    _same_answer(client.get(f"/v1/jobs/{job}", headers=BOB), client.get(f"/v1/jobs/{job}{ROUTED}", headers=BOB))
    missing = uuid.uuid4()
    _same_answer(client.get(f"/v1/jobs/{missing}", headers=ALICE), client.get(f"/v1/jobs/{missing}{ROUTED}", headers=ALICE))


def _bad_bodies_answer_as_the_route_does(client):
    for body in (b'{"values": []}', b'{"values": [1.0', b'{"values": ["1"]}', b'{"values": [666]}'):
        lean = client.post("/v1/test-compute/jobs", content=body, headers={**ALICE, "Content-Type": "application/json"})
        routed = client.post(f"/v1/test-compute/jobs{ROUTED}", content=body,
                             headers={**ALICE, "Content-Type": "application/json"})
        assert lean.status_code == 422, body
        _same_answer(lean, routed)


def test_refusals_answer_as_the_routes_do(client):
    _bad_bodies_answer_as_the_route_does(client)
    # a key the route's header validation refuses is left to the route: its 422 names the header
    long_key = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={**ALICE, "Idempotency-Key": "k" * 256})
    assert long_key.status_code == 422 and long_key.json()["errors"][0]["loc"] == ["header", "Idempotency-Key"]
    # no key: 401 before anything is read, with the request id and the security headers
    request_id = str(uuid.uuid4())
    refused = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={"X-Request-ID": request_id})
    assert refused.status_code == 401 and refused.headers["x-request-id"] == request_id
    assert refused.headers["x-content-type-options"] == "nosniff"


def test_submissions_read_on_the_event_loop_answer_as_the_routes_do(client):
    service = client.app.state.jobs
    first = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=ALICE)  # in a thread: imports checks
    assert first.status_code == 202 and service.intake_loaded("test-compute")
    # from here on a small body is read, checked and stored on the event loop
    _bad_bodies_answer_as_the_route_does(client)
    key = f"loop-{uuid.uuid4()}"
    new = client.post("/v1/test-compute/jobs", json={"values": [2.0]}, headers={**ALICE, "Idempotency-Key": key})
    assert new.status_code == 202
    read_back = client.get(f"/v1/jobs/{new.json()['id']}", headers=ALICE)
    assert new.content == read_back.content  # the view of the stored columns is the view of the stored row
    again = client.post("/v1/test-compute/jobs", json={"values": [2.0]}, headers={**ALICE, "Idempotency-Key": key})
    routed = client.post(f"/v1/test-compute/jobs{ROUTED}", json={"values": [2.0]},
                         headers={**ALICE, "Idempotency-Key": key})
    assert again.status_code == 200 and again.json()["id"] == new.json()["id"]
    _same_answer(again, routed)
    other = client.post("/v1/test-compute/jobs", json={"values": [3.0]}, headers={**ALICE, "Idempotency-Key": key})
    other_routed = client.post(f"/v1/test-compute/jobs{ROUTED}", json={"values": [3.0]},
                               headers={**ALICE, "Idempotency-Key": key})
    assert other.status_code == 422
    _same_answer(other, other_routed)


def test_lean_answers_carry_the_request_id_and_the_security_headers(client):
    request_id = str(uuid.uuid4())
    submitted = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers={**ALICE, "X-Request-ID": request_id})
    assert submitted.status_code == 202
    assert submitted.headers["x-request-id"] == request_id and submitted.headers["x-content-type-options"] == "nosniff"
    assert submitted.headers["content-type"] == "application/json" and "x-frame-options" not in submitted.headers
    status = client.get(f"/v1/jobs/{submitted.json()['id']}", headers={**ALICE, "X-Request-ID": "not a uuid"})
    assert status.status_code == 200
    assert uuid.UUID(status.headers["x-request-id"]).hex == status.headers["x-request-id"]  # a new one
    assert [name.lower() for name in status.headers.keys()].count("x-request-id") == 1
