"""Downloads stream from the blob store: artifacts (GET and HEAD) and submitted inputs keep their headers
(Content-Length, media type, X-Content-SHA256, file name) on every back-end; a missing blob is a 404 problem
(not a 500), an unreachable blob store a 503 with Retry-After. S3 runs against moto's S3 server."""

from __future__ import annotations

import hashlib
import json
import socket

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for
from tests.store.s3_server import moto_s3

NUMBERS = b"1.5\n2.5\n-4\n"


def _done(client, **submit) -> dict:
    response = client.post("/v1/test-compute/jobs", **submit)
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"])
    assert done["status"] == "succeeded", done
    return done


def test_missing_blobs_are_404_problems_not_500(client, settings):
    done = _done(client, files={"file": ("n.txt", NUMBERS, "text/plain")})
    job_id = done["id"]
    for path in (settings.resolved_artifact_dir / job_id).rglob("*"):  # the blobs go; the rows stay
        if path.is_file():
            path.unlink()
    for method, url in [("GET", f"/v1/jobs/{job_id}/artifacts/values.txt"),
                        ("HEAD", f"/v1/jobs/{job_id}/artifacts/values.txt"),
                        ("GET", f"/v1/jobs/{job_id}/input/file"),
                        ("GET", f"/v1/jobs/{job_id}/input")]:
        response = client.request(method, url)
        assert response.status_code == 404, (method, url, response.status_code)
        if method == "GET":
            problem = response.json()
            assert problem["status"] == 404 and "missing from the blob store" in problem["detail"]
            assert response.headers["content-type"] == "application/problem+json"


def test_downloads_stream_from_s3_with_their_headers_and_503_when_it_is_away(tmp_path):
    values = [i + 0.123456789 for i in range(100_000)]  # a ~1.6 MB JSON request: stored as a blob
    with moto_s3() as env:
        settings = service_settings(tmp_path, blob_store="s3", s3_bucket=env["S3_BUCKET"],
                                    s3_endpoint_url=env["S3_ENDPOINT_URL"], inline_input_bytes=64 * 1024)
        with TestClient(create_app(settings)) as client:
            uploaded = _done(client, files={"file": ("my numbers.txt", NUMBERS, "text/plain")})
            large = _done(client, json={"values": values})
            url = f"/v1/jobs/{uploaded['id']}/artifacts/values.txt"
            got = client.get(url)
            assert got.status_code == 200 and got.content == b"1.5\n2.5\n-4.0"
            assert got.headers["content-type"] == "text/plain; charset=utf-8"
            assert got.headers["content-length"] == str(len(got.content))
            assert got.headers["x-content-sha256"] == hashlib.sha256(got.content).hexdigest()
            assert got.headers["content-disposition"] == 'attachment; filename="values.txt"'
            head = client.head(url)
            assert head.status_code == 200 and head.content == b""
            assert {k: head.headers[k] for k in ("content-type", "content-length", "x-content-sha256",
                                                 "content-disposition")} == \
                   {k: got.headers[k] for k in ("content-type", "content-length", "x-content-sha256",
                                                "content-disposition")}
            listed = {a["name"]: a for a in uploaded["artifacts"]}["values.txt"]
            assert listed["sha256"] == got.headers["x-content-sha256"] and listed["size"] == len(got.content)
            # the upload, byte for byte, and its size in the input document
            file = client.get(f"/v1/jobs/{uploaded['id']}/input/file")
            assert file.content == NUMBERS and file.headers["content-length"] == str(len(NUMBERS))
            assert file.headers["content-disposition"] == 'attachment; filename="my_numbers.txt"'
            assert client.get(f"/v1/jobs/{uploaded['id']}/input").json()["size"] == len(NUMBERS)
            assert client.get(f"/v1/jobs/{uploaded['id']}/result").json()["total"] == 0.0
            # the large JSON request: streamed back from its blob, in more than one chunk
            stored = client.get(f"/v1/jobs/{large['id']}/input")
            assert stored.headers["content-type"] == "application/json"
            assert int(stored.headers["content-length"]) > 1024 * 1024 and json.loads(stored.content)["values"] == values
            assert client.get(f"/v1/jobs/{large['id']}/result").json()["total"] == pytest.approx(sum(values), rel=1e-12)
            # nothing landed on this machine's disk: S3 holds it all
            assert not [p for p in settings.resolved_artifact_dir.rglob("*") if p.is_file()]
        # the S3 server cannot be reached (the same bucket's jobs, the endpoint now a port nobody listens on)
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            away = settings.model_copy(update={"s3_endpoint_url": f"http://127.0.0.1:{probe.getsockname()[1]}"})
        with TestClient(create_app(away), raise_server_exceptions=False) as client:
            for method, url in [("GET", url), ("HEAD", url), ("GET", f"/v1/jobs/{uploaded['id']}/input/file")]:
                response = client.request(method, url)
                assert response.status_code == 503, (method, url, response.status_code, response.text)
                assert response.headers["retry-after"] and response.headers["x-request-id"]
                if method == "GET":
                    assert response.json()["type"].endswith("unavailable")
