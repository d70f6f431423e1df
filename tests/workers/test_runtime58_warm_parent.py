"""The embedded service's warm parent and job processes under repeated deaths (``bench/kill58.py`` runs them on a
real server): the warm parent imports every kind's solver (the upload readers' list had replaced the job processes'
one), a warm parent that dies at every start is tried again ever later instead of every second, a job whose process
dies before its claim again and again waits longer each time instead of being started again at once, and a job
process whose warm parent died with it is not said to have exited with code 255."""

from __future__ import annotations

import os
import time
import uuid
from multiprocessing import forkserver

import pytest

from plantsolve.app.main import create_app
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import SolverSpec
from plantsolve.workers import processes
from plantsolve.workers.processes import ProcessDispatcher, _Running, warm_modules
from tests.conftest import service_settings
from tests.support.dispatch import Recorder


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, embedded_mode="process"), migrate=True)
    yield context
    context.close()


def _queued(ctx) -> uuid.UUID:
    return JobService(ctx, Recorder(), readers=[]).submit_json("test-compute", b'{"values": [1]}', None).job.id


def test_the_warm_parent_imports_every_kinds_solver_and_the_upload_readers(tmp_path, monkeypatch):
    monkeypatch.setattr(forkserver, "ensure_running", lambda: None)  # the list is the point, not a started server
    app = create_app(service_settings(tmp_path, embedded_mode="process"))
    ctx = app.state.jobs.ctx
    preload = forkserver._forkserver._preload_modules
    # before: only the readers' modules (set after the job processes' list, replacing it): no kind's solve, no plugin
    solvers = [module for spec in ctx.kinds.values() for module in spec.modules(("solve", "render_artifacts"))]
    readers = [module for spec in ctx.kinds.values() for module in spec.modules(SolverSpec.READERS)]
    assert set(warm_modules(ctx.kinds.values(), ctx.settings.plugins)) <= set(preload)
    assert {"plantsolve.solvers.tube.solve", "tests.support.kinds", *solvers, *readers} <= set(preload)
    # the module that limits the numeric libraries to a thread each is imported before any of them
    assert preload[0] == "plantsolve.workers.processes"
    ctx.close()


class _DiesAtStart:
    """A warm parent that dies at every start: the probe's start fails as multiprocessing's does then."""

    starts: list[float] = []

    def __init__(self, *args, **kwargs):
        pass

    def start(self) -> None:
        _DiesAtStart.starts.append(time.monotonic())
        raise EOFError("unexpected EOF")


def test_a_warm_parent_that_dies_at_every_start_is_tried_again_ever_later_and_readiness_says_so(ctx, monkeypatch):
    monkeypatch.setattr(processes, "RETRY_SECONDS", 0.05)
    monkeypatch.setattr(processes, "WARM_BACKOFF_MAX", 0.4)
    monkeypatch.setattr(processes._warm, "Process", _DiesAtStart)
    _DiesAtStart.starts = []
    dispatcher = ProcessDispatcher(ctx, workers=1)
    dispatcher.start()
    try:
        job_id = _queued(ctx)
        dispatcher.enqueue(job_id, "test-compute")
        time.sleep(2.0)
        starts = list(_DiesAtStart.starts)
        # waits 0.05, 0.1, 0.2, 0.4, 0.4 ... s: 8 or 9 starts in 2 s (before: one every 0.05 s, 40)
        assert 5 <= len(starts) <= 10, starts
        gaps = [b - a for a, b in zip(starts, starts[1:])]
        assert all(later >= earlier * 0.9 for earlier, later in zip(gaps, gaps[1:])), gaps
        assert max(gaps) >= 0.35
        with pytest.raises(RuntimeError, match=r"warm parent failed \d+ start\(s\) in a row; the next in"):
            dispatcher.ping()
        # the job is held, not started (a start would start the warm parent before its pause) and not lost
        assert ctx.repo.get(job_id).status == "queued" and dispatcher.running() == {}
    finally:
        dispatcher.stop()


def test_a_job_whose_process_dies_before_its_claim_again_and_again_waits_longer_each_time(ctx, monkeypatch):
    monkeypatch.setattr(processes, "RETRY_SECONDS", 0.2)
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    # the first death in a row: back in line at once (a one-off kill mid-fork costs nothing)
    assert dispatcher._died_unclaimed(job_id) is True
    pauses = []
    for _ in range(3):
        now = time.monotonic()
        assert dispatcher._died_unclaimed(job_id) is False
        pauses.append(round(dispatcher._later[job_id][0] - now, 1))
    assert pauses == [0.2, 0.4, 0.8]  # before: started again at once, each time
    assert dispatcher._later[job_id][1] == "test-compute"
    # held meanwhile: a sweep's refill or another enqueue does not put it back in line early
    dispatcher._thread = object()  # enqueue refuses while no supervisor runs; none is needed here
    dispatcher.enqueue(job_id, "test-compute")
    dispatcher._back_in_line()
    assert list(dispatcher._waiting) == []
    dispatcher._later[job_id] = (time.monotonic() - 0.01, "test-compute")
    dispatcher._back_in_line()
    assert list(dispatcher._waiting) == [(job_id, "test-compute")] and dispatcher._later == {}
    assert ctx.repo.get(job_id).status == "queued" and ctx.repo.get(job_id).attempt == 0  # no attempt counted


class _Ended:
    """A job process as multiprocessing sees it once the warm parent that reports its end died: exit code 255."""

    def __init__(self, pid: int):
        self.pid, self.exitcode = pid, 255


def test_a_job_process_whose_warm_parent_died_too_is_not_said_to_have_exited_with_code_255(ctx):
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    worker = processes.worker_of(4_000_000)  # no such process
    assert ctx.repo.claim(job_id, lease_seconds=60, worker=worker) == 1
    gone_warm_parent = os.getpid()  # not a forkserver of this process
    child = _Running(job_id, _Ended(4_000_000), None, worker, None, None, time.monotonic(), gone_warm_parent)
    assert dispatcher._judge_end(child, None) is True  # re-queued
    job = ctx.repo.get(job_id)
    # before: "the job process exited with code 255" (multiprocessing's stand-in), though a SIGKILL had ended it
    how = "the job process died, how is not known (its exit status was lost: the process that reports it died too)"
    assert [(a["outcome"], a["error"]) for a in job.attempts] == [("lost", how)]
    assert "255" not in job.report["message"]
