"""Hostile HTTP, below the body's content: a compressed body, a misspelt query parameter, a body that trickles or
stops half way, a client that leaves. Each a quick 4xx problem document naming what is wrong (or, for a client that
left, nothing logged as an error), never a silent success, a 500 or a connection held open."""

from __future__ import annotations

import gzip
import json
import logging
import socket
import time
import uuid

import httpx
import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.live import live_server

PROBLEM = "application/problem+json"


@pytest.mark.parametrize("body", [gzip.compress(b'{"values": [3, 4]}'), b'{"values": [3, 4]}'], ids=["gzip", "plain"])
def test_a_body_with_a_content_encoding_is_a_415_naming_the_header(client, body):
    """A gzip body was read as text and refused as 'not valid JSON: utf-8 codec …'; a plain one labelled gzip was
    taken as if the label were not there."""
    headers = {"Content-Type": "application/json", "Content-Encoding": "gzip"}
    response = client.post("/v1/test-compute/jobs", content=body, headers=headers)
    assert response.status_code == 415 and response.headers["content-type"] == PROBLEM
    assert response.json()["errors"][0]["loc"] == ["header", "Content-Encoding"]
    files = {"file": ("n.txt", body, "text/plain")}
    assert client.post("/v1/test-compute/jobs", files=files, headers={"Content-Encoding": "gzip"}).status_code == 415
    assert client.post("/v1/test-compute/jobs", json={"values": [3, 4]},
                       headers={"Content-Encoding": "identity"}).status_code == 202


@pytest.mark.parametrize("url, unknown", [
    ("/v1/jobs?stauts=failed", "stauts"),  # was 200 with every job
    ("/v1/jobs?limit=5&created_after=2026-01-01", "created_after"),
    ("/v1/test-compute/jobs?callbackurl=https://example.com/hook", "callbackurl"),  # was 202 without a webhook
])
def test_a_query_parameter_the_route_does_not_take_is_a_422_naming_it(client, url, unknown):
    method = client.post if "test-compute" in url else client.get
    response = method(url, json={"values": [1]}) if method is client.post else method(url)
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    assert [e["loc"] for e in response.json()["errors"]] == [["query", unknown]]
    assert client.get("/v1/jobs").json()["items"] == []  # nothing was submitted


def test_the_query_parameters_a_route_takes_still_pass(client):
    response = client.post("/v1/test-compute/jobs?callback_url=https://example.com/hook", json={"values": [1]})
    # a 422 here may only be about the webhook's address (private ones are refused), never an unknown parameter
    assert response.status_code == 202 or ["query", "callback_url"] not in [
        e["loc"] for e in response.json()["errors"] if "unknown" in e["msg"]]
    assert response.status_code == 202 or all(e["type"] != "extra_forbidden" for e in response.json()["errors"])
    assert client.get("/v1/jobs?limit=5&status=queued&kind=test-compute").status_code == 200
    assert client.get("/healthz?anything=1").status_code == 200  # outside /v1: not checked
    # cache busters, and parameters on a route that takes none (nothing there can be misspelt), pass
    assert client.get("/v1/jobs?_=1700000000&limit=2").status_code == 200
    job = client.post("/v1/test-compute/jobs", json={"values": [1]}).json()
    assert client.get(f"/v1/jobs/{job['id']}?t=1700000000").status_code == 200


def _raw(port: int, head: bytes, body: bytes) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    sock.sendall(head + body)
    return sock


def _answer(sock: socket.socket) -> bytes:
    data = b""
    while chunk := sock.recv(65536):
        data += chunk
    return data


def _stalled(base: str, path: str, declared: int, sent: bytes) -> bytes:
    """The answer to a JSON POST that declares ``declared`` bytes and sends ``sent``, which must come within 5 s."""
    head = (f"POST {path} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            f"Content-Length: {declared}\r\n\r\n").encode()
    sock = _raw(int(base.rsplit(":", 1)[1]), head, sent)
    started = time.monotonic()
    answer = _answer(sock)
    sock.close()
    assert time.monotonic() - started < 5
    return answer


def test_a_body_that_stops_half_way_is_a_408_after_the_idle_time_not_a_connection_held_for_ever(tmp_path):
    """A client that declares 1000 bytes and sends 15 (or sends a byte now and then) held its connection and the
    request open for as long as it liked: the server waited without end."""
    app = create_app(service_settings(tmp_path, body_idle_seconds=0.5))
    with live_server(app) as base:
        answer = _stalled(base, "/v1/test-compute/jobs", 1000, b'{"values": [1],')
    status, _, rest = answer.partition(b"\r\n")
    assert status.startswith(b"HTTP/1.1 408") and b"application/problem+json" in rest.lower()
    assert b"after 15 bytes" in rest


def test_a_result_operations_stalled_or_oversized_body_answers_as_the_submit_route_does(tmp_path):
    """FastAPI reads an operation route's body itself and wrapped our bounds in 'error parsing the body': a stalled
    body was a 422 'not UTF-8 text' answered late, an oversized one a 422 'not valid JSON' instead of a 413."""
    path = f"/v1/perfmap/jobs/{uuid.uuid4()}/query"
    app = create_app(service_settings(tmp_path, body_idle_seconds=0.5, max_body_bytes=1000))
    with live_server(app) as base:
        answer = _stalled(base, path, 900, b'{"flow": 1')
        assert answer.startswith(b"HTTP/1.1 408") and b"application/problem+json" in answer.lower()
        big = {"points": [{"flow": 1000.0 + k, "pressure": 1.2} for k in range(100)]}
        with httpx.Client(base_url=base) as http:
            response = http.post(path, content=iter([json.dumps(big).encode()]),
                                 headers={"Content-Type": "application/json"})  # chunked: no length to refuse early
    assert response.status_code == 413 and response.headers["content-type"] == PROBLEM


def test_a_client_that_leaves_before_its_body_is_read_is_no_error_in_the_log(tmp_path, caplog):
    """A disconnect during the body of a JSON submission logged 'unhandled error' with two tracebacks."""
    app = create_app(service_settings(tmp_path))
    with live_server(app) as base, caplog.at_level(logging.INFO):
        port = int(base.rsplit(":", 1)[1])
        head = (b"POST /v1/test-compute/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                b"Content-Length: 100\r\n\r\n")
        sock = _raw(port, head, b'{"values": ')
        time.sleep(0.3)
        sock.close()
        time.sleep(0.5)
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], [r.getMessage() for r in caplog.records]
    assert any("disconnected before its body was read" in r.getMessage() for r in caplog.records)


def test_a_completed_body_may_wait_for_its_route_longer_than_the_idle_time(tmp_path):
    """The idle bound covers the body under way only: a route that then listens for the client's disconnect (an
    event stream) waits as long as it runs."""
    with TestClient(create_app(service_settings(tmp_path, body_idle_seconds=0.2))) as client:
        job_id = client.post("/v1/test-compute/jobs", json={"values": [3, 4], "seconds": 0.6}).json()["id"]
        with client.stream("GET", f"/v1/jobs/{job_id}/events") as events:
            text = "".join(events.iter_text())
        assert "succeeded" in text
