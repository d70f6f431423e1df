"""A warm parent stopped (SIGSTOP) while the service is idle: readiness says at once that no job can start (before, it
said 200 until a job's start had waited ``STALL_SECONDS`` on it), and the stopped warm parent is replaced without
waiting for a job to need it, so a job submitted later starts on a live one."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "X"


def _ready(client, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while client.get("/readyz").status_code != 200:
        assert time.monotonic() < deadline, client.get("/readyz").json()
        time.sleep(0.05)


def test_an_idle_stopped_warm_parent_makes_readiness_fail_at_once_and_is_replaced(tmp_path, monkeypatch):
    monkeypatch.setattr("plantsolve.workers.processes.STALL_SECONDS", 2.0)
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=1, sweep_seconds=600.0)
    with TestClient(create_app(settings)) as client:
        _ready(client)
        dispatcher = client.app.state.dispatcher
        warm = dispatcher._warm_parent
        os.kill(warm, signal.SIGSTOP)
        try:
            stopped = time.monotonic()
            while client.get("/readyz").status_code == 200:
                assert time.monotonic() - stopped < 1.5, "readiness said 200 while the warm parent was stopped"
                time.sleep(0.05)
            assert client.get("/readyz").json()["checks"]["jobs"] == "unavailable"
            # replaced while idle: no job had to wait on it first
            deadline = time.monotonic() + 60
            while _state(warm) not in ("Z", "X"):
                assert time.monotonic() < deadline, "the stopped warm parent was left in place"
                time.sleep(0.1)
        finally:
            if _state(warm) not in ("Z", "X"):
                os.kill(warm, signal.SIGCONT)
        _ready(client)
        assert dispatcher._warm_parent not in (None, warm)
        job = client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]}).json()["id"]
        started = time.monotonic()
        assert wait_for(client, job, timeout=60)["status"] == "succeeded"
        assert time.monotonic() - started < 10  # no start waited on a stopped warm parent
