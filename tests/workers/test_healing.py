"""The embedded service heals: any job process may die at any time — the idle warm parent or a busy job's
process, once or repeatedly — and jobs go on running, each solved exactly once, without a restart."""

from __future__ import annotations

import os
import signal
import time
import uuid
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def _ready(client, timeout: float = 120) -> float:
    started = time.monotonic()
    while client.get("/readyz").status_code != 200:
        assert time.monotonic() - started < timeout, client.get("/readyz").json()
        time.sleep(0.05)
    return time.monotonic() - started


def _runs(markers: Path) -> int:
    return len(list(markers.iterdir())) if markers.exists() else 0


@pytest.fixture
def service(tmp_path):
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=2, max_attempts=4,
                                sweep_seconds=600.0)  # no sweep: the supervisor alone must notice
    with TestClient(create_app(settings)) as client:
        _ready(client)
        yield client


def test_busy_job_processes_killed_again_and_again_each_job_still_solved_once(service, tmp_path):
    markers = tmp_path / "runs"
    body = {"values": [3.0, 4.0], "seconds": 1.0, "marker_dir": str(markers)}
    ids = [uuid.UUID(service.post("/v1/test-compute/jobs", json=body).json()["id"]) for _ in range(6)]
    dispatcher = service.app.state.dispatcher
    # the first two jobs are killed twice each, the next two once, the last two never
    kills = {job_id: 2 if i < 2 else 1 if i < 4 else 0 for i, job_id in enumerate(ids)}
    killed_pids: set[int] = set()
    deadline = time.monotonic() + 120
    while any(kills.values()):
        assert time.monotonic() < deadline, kills
        for job_id, pid in dispatcher.running().items():
            if kills.get(job_id) and pid not in killed_pids and service.get(f"/v1/jobs/{job_id}").json()["status"] == "running":
                os.kill(pid, signal.SIGKILL)
                killed_pids.add(pid)
                kills[job_id] -= 1
        time.sleep(0.05)
    views = [wait_for(service, str(job_id), timeout=120) for job_id in ids]
    assert [v["status"] for v in views] == ["succeeded"] * 6
    assert [[a["outcome"] for a in v["attempts"]] for v in views] == \
        [["lost", "lost", "succeeded"]] * 2 + [["lost", "succeeded"]] * 2 + [["succeeded"]] * 2
    assert all("killed by signal 9" in v["attempts"][0]["error"] for v in views[:4])
    assert _runs(markers) == 6  # a killed attempt stored nothing: each job was solved to the end once
    assert len(killed_pids) == 6


def test_a_killed_idle_warm_parent_is_started_again_and_jobs_go_on(service, tmp_path):
    markers = tmp_path / "runs"
    dispatcher = service.app.state.dispatcher
    for round_ in range(2):
        warm = dispatcher._warm_parent
        os.kill(warm, signal.SIGKILL)
        # readiness says no job can start until the warm parent is back
        deadline = time.monotonic() + 5
        while service.get("/readyz").status_code == 200:
            assert time.monotonic() < deadline, "readiness did not notice the dead warm parent"
            time.sleep(0.05)
        assert service.get("/readyz").json()["checks"]["jobs"] == "unavailable"
        ids = [service.post("/v1/test-compute/jobs", json={"values": [1.0], "marker_dir": str(markers)}).json()["id"]
               for _ in range(3)]
        assert [wait_for(service, job_id, timeout=180)["status"] for job_id in ids] == ["succeeded"] * 3
        assert dispatcher._warm_parent not in (None, warm)
        assert service.get("/readyz").status_code == 200
    assert _runs(markers) == 6


def test_a_hung_warm_parent_makes_readiness_fail_and_is_replaced_so_the_job_runs(service, tmp_path, monkeypatch):
    """A warm parent that is alive but does not answer (stopped here; deadlocked in the wild) would leave the next
    job's start waiting forever while readiness said 200 and the service took jobs it never ran."""
    monkeypatch.setattr("plantsolve.workers.processes.STALL_SECONDS", 2.0)
    markers = tmp_path / "runs"
    dispatcher = service.app.state.dispatcher
    warm = dispatcher._warm_parent
    os.kill(warm, signal.SIGSTOP)
    try:
        job_id = service.post("/v1/test-compute/jobs", json={"values": [1.0], "marker_dir": str(markers)}).json()["id"]
        deadline = time.monotonic() + 30
        while service.get("/readyz").status_code == 200:
            assert time.monotonic() < deadline, "readiness said 200 while no job could start"
            time.sleep(0.05)
        assert service.get("/readyz").json()["checks"]["jobs"] == "unavailable"
        assert wait_for(service, job_id, timeout=120)["status"] == "succeeded"
    finally:
        if not _gone(warm):
            os.kill(warm, signal.SIGCONT)
    assert _gone(warm) and dispatcher._warm_parent != warm
    assert _ready(service) < 60 and _runs(markers) == 1


def _gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state in ("Z", "X")
