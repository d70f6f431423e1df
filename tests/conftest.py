"""Shared fixtures: an isolated embedded service per test, and the real PostgreSQL/Redis
used by the integration tests (skipped with a printed reason outside CI when down; with
CI=true they must run)."""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # as `plantsolve` does
    os.environ.setdefault(_name, "1")

import time
import uuid
from pathlib import Path

import pytest

from plantsolve.app.settings import AppSettings
from tests.support.xdist_groups import pytest_collection_modifyitems  # noqa: F401  (a hook: pytest finds it here)
from tests.support.cpu_log import pytest_runtest_protocol  # noqa: F401  (a hook: PLANTSOLVE_TEST_CPU_LOG=<file>)

REPO = Path(__file__).resolve().parents[1]
PG_ADMIN_URL = os.environ.get("TEST_PG_ADMIN_URL", "postgresql://postgres@127.0.0.1:5432/postgres")
# one Redis database per pytest-xdist worker (gw0 -> 9, gw1 -> 10, ...): a session's flush never empties another's queue
REDIS_URL = os.environ.get(
    "TEST_REDIS_URL", f"redis://127.0.0.1:6379/{9 + int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0')[2:] or 0)}")


def service_settings(tmp_path: Path, **overrides) -> AppSettings:
    values = dict(
        data_dir=tmp_path,
        plugins=["tests.support.kinds"],
        heartbeat_seconds=0.2,
        lease_seconds=3.0,
        sweep_seconds=0.3,
        progress_write_seconds=0.0,
        embedded_mode="thread",  # fast app start-up; the process pool has its own tests
        min_free_disk_bytes=0,  # a CI machine short of disk is still ready for these tests; the floor has its own
    )
    values.update(overrides)
    return AppSettings(_env_file=None, **values)


@pytest.fixture(autouse=True)
def _plantsolve_logs_reach_caplog(caplog):
    """The plantsolve logger writes its own lines and does not propagate (see plantsolve.workers.logs):
    hand its records to caplog as well."""
    import logging

    logger = logging.getLogger("plantsolve")
    logger.addHandler(caplog.handler)
    yield
    logger.removeHandler(caplog.handler)


@pytest.fixture
def settings(tmp_path) -> AppSettings:
    return service_settings(tmp_path)


@pytest.fixture
def client(settings):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app

    with TestClient(create_app(settings)) as test_client:
        yield test_client


@pytest.fixture(scope="session")
def chromium_driver():
    """One headless Chromium for a test process's browser tests (20 s page loads), each on a fresh tab of it
    (tests.support.browser.page_on): a browser's start-up is CPU seconds, a fresh tab is what isolates a test.
    Skipped with the reason where there is none, failed with CI=true."""
    from tests.support import browser

    browser.require("browser tests")
    with browser.chromium() as driver:
        driver.set_page_load_timeout(20)
        yield driver


def wait_for(client, job_id: str, statuses=("succeeded", "failed", "cancelled"), timeout: float = 30.0, headers=None) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        view = client.get(f"/v1/jobs/{job_id}", headers=headers or {}).json()
        if view["status"] in statuses:
            return view
        if time.monotonic() > deadline:
            raise AssertionError(f"job {job_id} still {view['status']} after {timeout} s: {view}")
        time.sleep(0.05)


def run_plantsolve(args: list[str], cwd: Path, *, plugins: bool = False, timeout: float = 400):
    """Run the installed ``plantsolve`` command in a clean environment with DATA_DIR under cwd."""
    import subprocess
    import sys

    env = {"DATA_DIR": str(cwd / "var"), "PATH": "/usr/bin:/bin"}
    if plugins:
        env.update(PLUGINS="tests.support.kinds", PYTHONPATH=str(REPO))
    binary = Path(sys.executable).parent / "plantsolve"
    return subprocess.run([str(binary), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _unavailable(reason: str):
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{reason} (CI=true: the integration tests must run)")
    print(f"\nSKIP integration: {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="session")
def pg_url():
    """A fresh PostgreSQL database for this test session, dropped afterwards."""
    try:
        import psycopg

        admin = psycopg.connect(PG_ADMIN_URL, autocommit=True, connect_timeout=3)
    except Exception as error:
        _unavailable(f"PostgreSQL unreachable at {PG_ADMIN_URL}: {error}")
    name = f"plantsolve_test_{uuid.uuid4().hex[:10]}"
    admin.execute(f'CREATE DATABASE "{name}"')
    base = PG_ADMIN_URL.rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://")
    try:
        yield f"{base}/{name}"
    finally:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


@pytest.fixture(scope="session")
def redis_url():
    try:
        import redis

        connection = redis.Redis.from_url(REDIS_URL, socket_connect_timeout=3)
        connection.ping()
    except Exception as error:
        _unavailable(f"Redis unreachable at {REDIS_URL}: {error}")
    connection.flushdb()
    yield REDIS_URL
    connection.flushdb()
