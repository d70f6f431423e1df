"""Supervision of the embedded pool: a stop hands running jobs back to the queue (their attempt not
counted) and ends the job processes within its stated time; job processes die with the service."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.workers.processes import STOP_SECONDS
from tests.conftest import REPO, service_settings, wait_for


def _wait_running(client, job_id: str, timeout: float = 60) -> dict:
    return wait_for(client, job_id, statuses=("running",), timeout=timeout)


def test_a_stop_hands_the_running_job_back_and_the_next_start_runs_it_again(tmp_path):
    markers = tmp_path / "runs"
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=1)
    body = {"values": [1.0, 2.0], "seconds": 30, "marker_dir": str(markers)}
    with TestClient(create_app(settings)) as client:
        job_id = client.post("/v1/test-compute/jobs", json=body).json()["id"]
        _wait_running(client, job_id)
        started = time.monotonic()
    stopped_in = time.monotonic() - started
    assert stopped_in < STOP_SECONDS + 5
    with TestClient(create_app(settings)) as client:
        view = client.get(f"/v1/jobs/{job_id}").json()
        assert view["attempts"][0]["outcome"] == "handed_back"
        assert view["max_attempts"] == 4  # the stopped attempt is not counted against the job
        again = wait_for(client, job_id, statuses=("running",), timeout=120)  # the next start runs it again
        assert again["attempt"] == 2
        client.post(f"/v1/jobs/{job_id}/cancel")
    assert not markers.exists() or not list(markers.iterdir())  # the stopped attempt stored nothing


def _children(pid: int) -> set[int]:
    found = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        found |= {int(p) for p in (task / "children").read_text().split()}
    return found


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")[:200]
    except OSError:
        return "?"


def _descendants(pid: int) -> set[int]:
    """Children, grandchildren …: a job process is a child of the warm parent, itself a child of the service."""
    found, todo = set(), [pid]
    while todo:
        try:
            children = _children(todo.pop())
        except FileNotFoundError:
            continue
        found |= children
        todo += children
    return found


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    status = Path(f"/proc/{pid}/status").read_text() if Path(f"/proc/{pid}").exists() else ""
    return "State:\tZ" not in status


class Served:
    """``plantsolve serve`` in a subprocess on a free loopback port (embedded default, one job process)."""

    def __init__(self, tmp_path: Path):
        sock = socket.socket()
        sock.bind(("127.0.0.1", 0))
        self.port = sock.getsockname()[1]
        sock.close()
        self.base = f"http://127.0.0.1:{self.port}"
        env = {"DATA_DIR": str(tmp_path / "var"), "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
               "PYTHONPATH": str(REPO), "PLUGINS": "tests.support.kinds", "EMBEDDED_WORKERS": "1", "LOG_FORMAT": "text",
               "MIN_FREE_DISK_BYTES": "0"}  # a CI machine short of disk: these tests are about the job processes
        binary = Path(sys.executable).parent / "plantsolve"
        self.process = subprocess.Popen([str(binary), "serve", "--port", str(self.port)], cwd=tmp_path, env=env,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 90
        while True:
            try:
                if httpx.get(f"{self.base}/readyz", timeout=2).status_code == 200:
                    return
            except httpx.HTTPError:
                pass
            assert time.monotonic() < deadline and self.process.poll() is None, "the service did not start"
            time.sleep(0.2)

    def running_job(self, body: dict) -> str:
        job_id = httpx.post(f"{self.base}/v1/test-compute/jobs", json=body, timeout=10).json()["id"]
        deadline = time.monotonic() + 60
        while httpx.get(f"{self.base}/v1/jobs/{job_id}", timeout=5).json()["status"] != "running":
            assert time.monotonic() < deadline
            time.sleep(0.1)
        return job_id

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()


@pytest.fixture
def served(tmp_path):
    server = Served(tmp_path)
    yield server
    server.close()


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux /proc")
def test_job_processes_die_with_a_killed_service_and_write_nothing(served, tmp_path):
    markers = tmp_path / "runs"
    seconds = 4  # long enough to be killed while running: the kill follows the running status at once
    served.running_job({"values": [1.0], "seconds": seconds, "marker_dir": str(markers)})
    running_at = time.monotonic()
    workers = _descendants(served.process.pid)
    assert len(workers) >= 2  # the warm parent and the job's process
    served.process.send_signal(signal.SIGKILL)
    served.process.wait(timeout=10)
    # the job process at once (its parent's pipe closed); the warm parent and multiprocessing's resource tracker when
    # the last process holding their pipes is gone (a loaded machine takes seconds)
    gone_by = time.monotonic() + 10
    while any(_alive(pid) for pid in workers) and time.monotonic() < gone_by:
        time.sleep(0.1)
    left = {pid: _cmdline(pid) for pid in workers if _alive(pid)}
    assert not left, f"a process outlived its service: {left}"
    time.sleep(max(0.0, running_at + seconds + 1.0 - time.monotonic()))  # past the moment the solve would have finished
    assert not markers.exists() or not list(markers.iterdir()), "an orphan finished the job"


def test_sigterm_drains_within_its_stated_time_and_hands_the_job_back(served, tmp_path):
    from plantsolve.cli import SHUTDOWN_SECONDS

    job_id = served.running_job({"values": [1.0], "seconds": 60})
    started = time.monotonic()
    served.process.send_signal(signal.SIGTERM)
    served.process.wait(timeout=SHUTDOWN_SECONDS + STOP_SECONDS + 20)
    assert time.monotonic() - started < SHUTDOWN_SECONDS + STOP_SECONDS + 5
    # the job as the same data directory now holds it, read through the API without running it (a second `serve`
    # would start job processes only to run the handed-back job into the test's end): queued again, the stopped
    # attempt not counted
    with TestClient(create_app(service_settings(tmp_path / "var"), run_jobs=False)) as again:
        view = again.get(f"/v1/jobs/{job_id}").json()
    assert view["status"] == "queued"
    assert view["attempts"][0]["outcome"] == "handed_back" and view["max_attempts"] == 4
