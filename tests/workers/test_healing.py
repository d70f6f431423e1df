"""The embedded service heals: any job process may die at any time — the idle warm parent or a busy job's
process, once or repeatedly — and jobs go on running, each solved exactly once, without a restart."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.workers.processes import ProcessDispatcher, is_warm_parent
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


def test_a_hung_warm_parent_is_found_and_killed_even_when_the_pid_known_for_it_now_names_another_process(
        service, tmp_path, monkeypatch):
    """The pid learnt at the last warm-up may be stale (the forkserver died unnoticed and the start restarted it) and,
    once reaped, reused by an unrelated process: that process must be left alone and the forkserver the start
    really waits on must be killed."""
    monkeypatch.setattr("plantsolve.workers.processes.STALL_SECONDS", 2.0)
    markers = tmp_path / "runs"
    dispatcher = service.app.state.dispatcher
    warm = dispatcher._warm_parent
    bystander = subprocess.Popen(["sleep", "120"])  # a child of this process, as a reused pid could be
    os.kill(warm, signal.SIGSTOP)
    try:
        job_id = service.post("/v1/test-compute/jobs", json={"values": [1.0], "marker_dir": str(markers)}).json()["id"]
        deadline = time.monotonic() + 30
        while dispatcher._start_began is None:  # the start waits on the stopped warm parent
            assert time.monotonic() < deadline, "no start began"
            time.sleep(0.01)
        dispatcher._warm_parent = bystander.pid
        assert wait_for(service, job_id, timeout=120)["status"] == "succeeded"
        assert bystander.poll() is None, "an unrelated process was killed for the warm parent"
    finally:
        if not _gone(warm):
            os.kill(warm, signal.SIGCONT)
        bystander.kill()
        bystander.wait()
    assert _gone(warm) and dispatcher._warm_parent not in (warm, bystander.pid)
    assert _ready(service) < 60 and _runs(markers) == 1


def test_a_running_job_still_ends_at_its_hard_limit_after_its_warm_parent_was_killed(service, tmp_path, monkeypatch):
    """Killing the warm parent ends the running jobs' multiprocessing sentinels: their Process objects then believe
    they ended (exit code 255) and would kill nothing at the deadline while the job ran on."""
    monkeypatch.setattr("plantsolve.workers.processes.STALL_SECONDS", 2.0)
    markers = tmp_path / "runs"
    dispatcher = service.app.state.dispatcher
    started = time.monotonic()
    stubborn = service.post("/v1/test-stubborn/jobs", json={}).json()["id"]
    wait_for(service, stubborn, statuses=("running",), timeout=60)
    stubborn_pid = dispatcher.running()[uuid.UUID(stubborn)]
    warm = dispatcher._warm_parent
    os.kill(warm, signal.SIGSTOP)
    try:  # the next start hangs on the stopped warm parent, which is killed under the running job
        job_id = service.post("/v1/test-compute/jobs", json={"values": [1.0], "marker_dir": str(markers)}).json()["id"]
        done = wait_for(service, stubborn, timeout=90)
        assert done["status"] == "failed" and done["report"]["stage"] == "time_limit"
        assert done["report"]["details"]["killed"] is True
        assert wait_for(service, job_id, timeout=120)["status"] == "succeeded"
    finally:
        if not _gone(warm):
            os.kill(warm, signal.SIGCONT)
    assert _gone(warm) and _gone(stubborn_pid)
    assert time.monotonic() - started < 90


def test_a_stop_ends_the_start_watch_so_a_quick_restart_has_one(service, monkeypatch):
    """A watcher busy when ``stop()`` then ``start()`` ran (its stop event set and cleared meanwhile) would go on
    beside the new one."""
    release = threading.Event()
    checked = threading.Event()

    def busy_stall_check(self) -> bool:  # the watcher caught in the middle of its look at the start under way
        if threading.current_thread().name == "job-start-watch":
            checked.set()
            release.wait(10)
        return False

    monkeypatch.setattr(ProcessDispatcher, "_start_stalled", busy_stall_check)
    dispatcher = service.app.state.dispatcher
    assert checked.wait(10)
    threading.Timer(1.0, release.set).start()
    dispatcher.stop()
    dispatcher.start()
    release.set()
    time.sleep(1.0)  # a watcher that missed the stop loops on
    assert [t.name for t in threading.enumerate() if t.name == "job-start-watch"] == ["job-start-watch"]


def test_only_this_processs_own_forkserver_is_taken_for_the_warm_parent(tmp_path):
    """A pid is the warm parent only while it runs, is a child of this process and runs the forkserver: once the
    dead one is reaped, its pid may name an unrelated process."""
    fake = "from multiprocessing.forkserver import main; import time; time.sleep(60)"
    child = subprocess.Popen([sys.executable, "-c", fake])
    grandchild_pid = tmp_path / "pid"
    shell = subprocess.Popen(["sh", "-c", f'"{sys.executable}" -c "{fake}" & echo $! > {grandchild_pid}; wait'])
    other = subprocess.Popen(["sleep", "60"])
    try:
        deadline = time.monotonic() + 10
        while not (grandchild_pid.exists() and grandchild_pid.read_text().strip()):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        time.sleep(0.2)  # the exec has happened
        assert is_warm_parent(child.pid)
        assert not is_warm_parent(int(grandchild_pid.read_text()))  # a forkserver, not this process's
        assert not is_warm_parent(other.pid)  # this process's, not a forkserver
        child.kill()
        child.wait()
        assert not is_warm_parent(child.pid)
    finally:
        for process in (child, other, shell):
            process.kill()
            process.wait()
        if grandchild_pid.exists():
            os.kill(int(grandchild_pid.read_text()), signal.SIGKILL)
