"""A dispatcher can be stopped and started again in one process (an app's lifespan run twice, a test harness):
its sweeper then runs again, one thread of it, and lapsed leases are still swept after the restart."""

from __future__ import annotations

import threading
import time

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.service import JobService
from plantsolve.workers.embedded import EmbeddedDispatcher
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings


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
