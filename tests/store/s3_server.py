"""A local S3-compatible server for the BLOB_STORE=s3 tests: moto's server mode (``ThreadedMotoServer``, an
HTTP server in a thread of the test process, reachable by worker subprocesses too), with a fresh bucket.

moto missing is a skip with a printed reason outside CI, a failure with CI=true (it is in the test extra)."""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from typing import Iterator

import pytest

# any credentials do for moto; boto3 reads them from the environment, as a deployment would
CREDENTIALS = {"AWS_ACCESS_KEY_ID": "plantsolve-test", "AWS_SECRET_ACCESS_KEY": "plantsolve-test-secret",
               "AWS_DEFAULT_REGION": "us-east-1"}


def _unavailable(reason: str) -> None:
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{reason} (CI=true: the S3 tests must run)")
    print(f"\nSKIP s3: {reason}")
    pytest.skip(reason)


@contextmanager
def moto_s3() -> Iterator[dict[str, str]]:
    """Starts the server, creates a bucket; yields the settings' environment (S3_ENDPOINT_URL, S3_BUCKET and
    the credentials), which it also sets in this process's environment while it runs."""
    try:
        import boto3
        from moto.server import ThreadedMotoServer
    except ImportError as error:
        _unavailable(f"moto's S3 server cannot be imported ({error}); `make install` installs the test extra")
    server = ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    saved = {name: os.environ.get(name) for name in CREDENTIALS}
    os.environ.update(CREDENTIALS)
    try:
        host, port = server.get_host_and_port()
        env = {**CREDENTIALS, "BLOB_STORE": "s3", "S3_ENDPOINT_URL": f"http://{host}:{port}",
               "S3_BUCKET": f"plantsolve-test-{uuid.uuid4().hex[:8]}"}
        boto3.client("s3", endpoint_url=env["S3_ENDPOINT_URL"]).create_bucket(Bucket=env["S3_BUCKET"])
        yield env
    finally:
        server.stop()
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
