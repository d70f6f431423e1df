"""The embedded service's warm parent and job processes under repeated deaths (``bench/kill58.py`` runs them on a
real server): the warm parent imports every kind's solver (the upload readers' list had replaced the job processes'
one), a warm parent that dies at every start is tried again ever later instead of every second (and an upload starts
none while its starts are paused: a 503), a job whose process
dies before its claim again and again waits longer each time instead of being started again at once, and a job
process whose warm parent died with it is not said to have exited with code 255."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import time
import uuid
from multiprocessing import forkserver

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs import intake
from plantsolve.jobs.backoff import Backoff
from plantsolve.solvers.base import SolverSpec
from plantsolve.workers import processes
from plantsolve.workers.processes import ProcessDispatcher, warm_modules
from tests.conftest import service_settings
from tests.support.dispatch import queued_test_job


_queued = queued_test_job


def test_the_warm_parent_imports_every_kinds_solver_and_the_upload_readers(tmp_path, monkeypatch):
    monkeypatch.setattr(forkserver, "ensure_running", lambda: None)  # the list is the point, not a started server
    # as an earlier test of this process leaves it: the readers' list asked for first (a service without job processes)
    monkeypatch.setattr(intake, "_preloaded", {})
    monkeypatch.setattr(forkserver._forkserver, "_preload_modules", list(forkserver._forkserver._preload_modules))
    intake.preload_in_forkserver(["plantsolve.jobs.intake", "plantsolve.solvers.tube.upload"])
    app = create_app(service_settings(tmp_path, embedded_mode="process"))
    ctx = app.state.jobs.ctx
    preload = forkserver._forkserver._preload_modules
    # before: only the readers' modules (set after the job processes' list, replacing it): no kind's solve, no plugin
    solvers = [module for spec in ctx.kinds.values() for module in spec.modules(("solve", "render_artifacts"))]
    readers = [module for spec in ctx.kinds.values() for module in spec.modules(SolverSpec.READERS)]
    assert set(warm_modules(ctx.kinds.values(), ctx.settings.plugins)) <= set(preload)
    assert {"plantsolve.solvers.tube.solve", "tests.support.kinds", *solvers, *readers} <= set(preload)
    # the module that limits the numeric libraries to a thread each is imported before any of them, whoever asked first
    # (before: the readers' modules came first when they had been asked for first)
    assert preload[0] == "plantsolve.workers.processes"
    ctx.close()


class _DiesAtStart:
    """A forkserver that dies at every start: a process's start fails as multiprocessing's does then."""

    starts: list[float] = []

    def __init__(self, *args, **kwargs):
        pass

    def start(self) -> None:
        _DiesAtStart.starts.append(time.monotonic())
        raise EOFError("unexpected EOF")


@pytest.fixture
def starts(fresh_forkserver_starts, monkeypatch):
    """The process's forkserver gate, fresh (tests/workers/conftest.py), with short pauses: 0, 0.05, 0.1, 0.2, 0.4,
    0.4 ... s."""
    gate = fresh_forkserver_starts
    monkeypatch.setattr(gate, "backoff", Backoff(first=0.05, longest=0.4))
    _DiesAtStart.starts = []
    return gate


def test_a_warm_parent_that_dies_at_every_start_is_tried_again_ever_later_and_readiness_says_so(ctx, starts,
                                                                                                  monkeypatch):
    monkeypatch.setattr(processes._warm, "Process", _DiesAtStart)
    dispatcher = ProcessDispatcher(ctx, workers=1)
    dispatcher.start()
    try:
        job_id = _queued(ctx)
        dispatcher.enqueue(job_id, "test-compute")
        time.sleep(2.0)
        tried = list(_DiesAtStart.starts)
        # at 0, 0, 0.05, 0.15, 0.35, 0.75, 1.15, 1.55, 1.95 s: 8 or 9 starts in 2 s (before: one a second for ever,
        # at whatever the cost of a start)
        assert 5 <= len(tried) <= 10, tried
        gaps = [b - a for a, b in zip(tried, tried[1:])]
        assert gaps[0] < 0.15 and min(gaps[-3:]) >= 0.35, gaps  # at once, then up to the longest pause
        # a pause that lasts from the next failed start on: ping() cannot fall between its end and the next start
        # (it said "is starting" then)
        monkeypatch.setattr(starts, "backoff", Backoff(first=1.0, longest=60.0))
        counted = starts.current()
        until = time.monotonic() + 10
        while starts.current() == counted and time.monotonic() < until:
            time.sleep(0.01)
        with pytest.raises(RuntimeError, match=r"warm parent failed \d+ start\(s\) in a row; the next in"):
            dispatcher.ping()
        # the job is held, not started (a start would start the warm parent before its pause) and not lost
        assert ctx.repo.get(job_id).status == "queued" and dispatcher.running() == {}
    finally:
        dispatcher.stop()


def test_an_upload_is_a_503_without_a_forkserver_start_while_its_starts_are_paused(tmp_path, starts, monkeypatch):
    monkeypatch.setattr(forkserver, "ensure_running", lambda: None)  # no readers' forkserver started by the app
    monkeypatch.setattr(starts, "backoff", Backoff(first=5.0, longest=30.0))
    forkserver_context = multiprocessing.get_context("forkserver")
    monkeypatch.setattr(forkserver_context, "Process", _DiesAtStart)
    with TestClient(create_app(service_settings(tmp_path))) as client:
        said = [client.post("/v1/test-compute/jobs", files={"file": ("v.txt", b"1.5\n")}) for _ in range(4)]
        assert client.get("/v1/jobs").json()["items"] == []  # nothing stored
    assert [r.status_code for r in said] == [503] * 4 and all(r.headers.get("retry-after") for r in said)
    # the first failure is tried again at once, the second pauses the starts: the last two uploads start nothing
    # (before: each upload started a forkserver, which imports every kind, and saw it die)
    assert len(_DiesAtStart.starts) == 2 and starts.failures == 2 and starts.pause_left() > 0


def test_a_job_whose_process_dies_before_its_claim_again_and_again_waits_longer_each_time(ctx, monkeypatch):
    monkeypatch.setattr(processes, "UNCLAIMED_RESTARTS", Backoff(first=0.2, longest=30.0))
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    child = _died_before_its_claim(job_id)
    # the first death in a row: back in line at once (a one-off kill mid-fork costs nothing)
    assert dispatcher._judge_end(child, None) is True
    for pause in (0.2, 0.4, 0.8):  # before: started again at once, each time
        before = time.monotonic()
        assert dispatcher._judge_end(child, None) is False
        due = dispatcher._later[job_id][0]
        assert before + pause <= due <= time.monotonic() + pause
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


def _died_before_its_claim(job_id: uuid.UUID) -> processes._Running:
    """A job process of ``job_id`` (a queued job) that ended without a word."""
    worker = processes.worker_of(4_000_000)  # no such process
    return processes._Running(job_id, _Ended(4_000_000), None, worker, None, None, time.monotonic(), None,
                              "test-compute")


def test_a_job_process_whose_warm_parent_died_too_is_not_said_to_have_exited_with_code_255(ctx):
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    worker = processes.worker_of(4_000_000)  # no such process
    assert ctx.repo.claim(job_id, lease_seconds=60, worker=worker) == 1
    gone_warm_parent = os.getpid()  # not a forkserver of this process
    child = processes._Running(job_id, _Ended(4_000_000), None, worker, None, None, time.monotonic(),
                               gone_warm_parent)
    assert dispatcher._judge_end(child, None) is True  # re-queued
    job = ctx.repo.get(job_id)
    # before: "the job process exited with code 255" (multiprocessing's stand-in), though a SIGKILL had ended it
    how = "the job process died, how is not known (its exit status was lost: the process that reports it died too)"
    assert [(a["outcome"], a["error"]) for a in job.attempts] == [("lost", how)]
    assert "255" not in job.report["message"]


def test_a_job_process_whose_warm_parent_lives_keeps_its_exit_code_255(ctx):
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    worker = processes.worker_of(4_000_000)  # no such process
    assert ctx.repo.claim(job_id, lease_seconds=60, worker=worker) == 1
    # a running forkserver of this process, as is_warm_parent knows one (its command line), without its imports
    warm_parent = subprocess.Popen([sys.executable, "-c", "from multiprocessing.forkserver import main; "
                                    "import time; time.sleep(60)"])
    try:
        assert processes.is_warm_parent(warm_parent.pid)
        child = processes._Running(job_id, _Ended(4_000_000), None, worker, None, None, time.monotonic(),
                                   warm_parent.pid)
        assert dispatcher._judge_end(child, None) is True
    finally:
        warm_parent.kill()
        warm_parent.wait()
    # the warm parent reported it: the code is the job process's own
    job = ctx.repo.get(job_id)
    assert [(a["outcome"], a["error"]) for a in job.attempts] == [("lost", "the job process exited with code 255")]
