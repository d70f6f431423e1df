"""Restarts: a dispatcher can be stopped and started again in one process (an app's lifespan run twice, a test
harness): its sweeper then runs again, one thread of it, and lapsed leases are still swept after the restart. A
service started again after it was killed runs the jobs its dead job processes held at once."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import sweep_once
from plantsolve.jobs.service import JobService
from plantsolve.workers.embedded import EmbeddedDispatcher
from plantsolve.workers.processes import ProcessDispatcher, job_process_pid, worker_of
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings, wait_for


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, sweep_seconds=0.1), migrate=True)
    yield context
    context.close()


def _sweepers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "sweeper" and t.is_alive()]


def test_a_dispatcher_stopped_and_started_again_sweeps_lapsed_leases_again(ctx):
    dispatcher = EmbeddedDispatcher(ctx, workers=1)
    dispatcher.start()
    dispatcher.stop()
    dispatcher.start()  # before: RuntimeError "threads can only be started once", from the sweeper
    try:
        assert len(_sweepers()) == 1
        job_id = JobService(ctx, dispatcher).submit_json("test-compute", b'{"values": [3, 4]}', None).job.id
        deadline = time.monotonic() + 10
        while ctx.repo.get(job_id).status != "succeeded":
            assert time.monotonic() < deadline
            time.sleep(0.05)
        # a worker that claims and dies: only the restarted sweeper can give the job back
        again = JobService(ctx, _Nowhere()).submit_json("test-compute", b'{"values": [6, 8]}', None).job.id
        assert ctx.repo.claim(again, lease_seconds=0.05, worker="killed") == 1
        while ctx.repo.get(again).status != "succeeded":
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert [a["outcome"] for a in ctx.repo.get(again).attempts] == ["lost", "succeeded"]
    finally:
        dispatcher.stop()
    assert not _sweepers()


def test_a_stop_ends_a_pass_under_way_after_it_and_a_start_twice_runs_one_loop(ctx):
    passes: list[str] = []
    entered, release = threading.Event(), threading.Event()

    def slow_after_pass() -> None:  # the pass is under way when stop() and start() run
        passes.append(threading.current_thread().name)
        entered.set()
        release.wait(5)

    sweeper = Sweeper(ctx, lambda job_id, kind: None, after_pass=slow_after_pass)
    sweeper.start()
    sweeper.start()
    assert entered.wait(5) and len(_sweepers()) == 1
    threading.Timer(0.5, release.set).start()
    sweeper.stop()  # waits for the pass under way
    assert not _sweepers()
    release.clear()
    sweeper.start()
    entered.clear()
    assert entered.wait(5) and len(_sweepers()) == 1
    release.set()
    sweeper.stop()
    assert not _sweepers()


class _Nowhere:
    """A queue that loses every message: the job row waits for the sweeper."""

    in_process = True

    def enqueue(self, job_id, kind=""):
        pass


def test_a_job_whose_process_died_with_a_killed_service_runs_again_at_the_next_start_not_a_lease_later(tmp_path):
    """A service killed outright (SIGKILL, power cut) leaves its running job's row 'running', held by a job process
    that died with it. The next start on this host sees that process gone and runs the job at once: before, the row
    said 'running' for a whole lease (60 s by default) while nothing ran it."""
    settings = service_settings(tmp_path, embedded_mode="process", lease_seconds=600.0, sweep_seconds=600.0)
    ctx = ServiceContext.create(settings, migrate=True)
    try:
        job_id = JobService(ctx, _Nowhere()).submit_json("test-compute", b'{"values": [3, 4]}', None).job.id
        dead = subprocess.Popen(["true"])
        dead.wait()  # a pid that ran a job process of this host and is gone
        assert ctx.repo.claim(job_id, lease_seconds=600.0, worker=worker_of(dead.pid)) == 1
    finally:
        ctx.close()
    with TestClient(create_app(settings)) as client:
        view = wait_for(client, str(job_id), timeout=60)
    assert view["status"] == "succeeded"
    assert [(a["outcome"], a["attempt"]) for a in view["attempts"]] == [("lost", 1), ("succeeded", 2)]
    assert f"{worker_of(dead.pid)} is gone" in view["attempts"][0]["error"]


def test_a_job_process_that_still_runs_or_is_another_hosts_keeps_its_claim(tmp_path):
    settings = service_settings(tmp_path, embedded_mode="process", lease_seconds=600.0, sweep_seconds=600.0)
    ctx = ServiceContext.create(settings, migrate=True)
    try:
        service = JobService(ctx, _Nowhere())
        alive, elsewhere = (service.submit_json("test-compute", b'{"values": [1]}', None).job.id for _ in range(2))
        ctx.repo.claim(alive, lease_seconds=600.0, worker=worker_of(os.getpid()))
        ctx.repo.claim(elsewhere, lease_seconds=600.0, worker="process@another-host:1")
        dispatcher = ProcessDispatcher(ctx)
        assert not dispatcher.orphan_gone(worker_of(os.getpid()))
        assert not dispatcher.orphan_gone("process@another-host:1")
        assert not dispatcher.orphan_gone("celery@" + worker_of(1).split("@", 1)[1])
        assert job_process_pid(worker_of(123)) == 123 and job_process_pid(None) is None
        # a container of the same host name in another pid namespace: not this host's process to judge
        host = worker_of(1).rsplit(":", 1)[0]
        assert not dispatcher.orphan_gone(f"{host.split('~')[0]}~1:{4_194_000}")
        assert not dispatcher.orphan_gone(f"{host.split('~')[0]}:{4_194_000}")  # nor one naming no namespace
        sweep_once(ctx, lambda *a: None, gone=dispatcher.orphan_gone)
        assert ctx.repo.get(alive).status == ctx.repo.get(elsewhere).status == "running"
    finally:
        ctx.close()


def test_a_stopped_job_process_is_killed_once_its_lease_lapsed_and_the_job_runs_again_at_once(tmp_path):
    """A job process stopped (SIGSTOP, a hung native call) stops heartbeating: the sweep gives its job back when the
    lease lapses. Before, the stopped process kept its place and its job in the pool until the kind's hard time limit
    (90 s here, most kinds' ten minutes and more): the job, queued again, could not start meanwhile."""
    markers = tmp_path / "runs"
    settings = service_settings(tmp_path, embedded_mode="process", embedded_workers=1, lease_seconds=1.5,
                                heartbeat_seconds=0.3, sweep_seconds=0.3)
    with TestClient(create_app(settings)) as client:
        job_id = client.post("/v1/test-compute/jobs", json={"values": [3, 4], "seconds": 1.5,
                                                            "marker_dir": str(markers)}).json()["id"]
        wait_for(client, job_id, statuses=("running",), timeout=60)
        (pid,) = client.app.state.dispatcher.running().values()
        os.kill(pid, signal.SIGSTOP)
        stopped = time.monotonic()
        try:
            view = wait_for(client, job_id, timeout=30)
        finally:
            _continue(pid)
        assert time.monotonic() - stopped < 30
        assert view["status"] == "succeeded" and [a["outcome"] for a in view["attempts"]] == ["lost", "succeeded"]
        assert len(list(markers.iterdir())) == 1  # solved once: the stopped attempt never finished
        assert not _alive(pid)


def _alive(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def _continue(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGCONT)
    except ProcessLookupError:
        pass
