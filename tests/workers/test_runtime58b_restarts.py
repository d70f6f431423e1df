"""Restarts of the forkserver and of job processes, as seen once (runtime58's review): one forkserver death seen by
several callers counts once; a hung process killed after the sweep re-queued its job did not die before its claim;
the count of deaths before the claim ends with any other end; an upload during a pause stores nothing; the ends of
job processes killed with the warm parent are judged before its next start."""

from __future__ import annotations

import multiprocessing
import signal
import subprocess
import threading
import time
import uuid
from multiprocessing import forkserver

from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.jobs import intake
from plantsolve.jobs.backoff import Backoff
from plantsolve.jobs.errors import INFRASTRUCTURE
from plantsolve.jobs.intake import ForkserverStarts
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import load_kinds
from plantsolve.workers import processes
from plantsolve.workers.processes import ProcessDispatcher
from tests.conftest import service_settings
from tests.support.dispatch import queued_test_job

PLUGINS = ("tests.support.kinds",)


def test_a_forkserver_failure_seen_by_several_callers_counts_once():
    gate = ForkserverStarts(Backoff(first=1.0, longest=30.0))
    start = gate.current()
    # three uploads waiting on it and the dispatcher see the one death: before, failures=4 and a 4 s pause
    assert [gate.failed(start) for _ in range(4)] == [0.0] * 4 and gate.failures == 1 and gate.pause_left() == 0
    again = gate.current()
    assert again != start
    assert gate.failed(again) == 1.0 and gate.failures == 2  # the next start's failure is a second one
    late = gate.failed(start)  # a caller of the first start that reports only now adds nothing
    assert gate.failures == 2 and 0.9 < late <= 1.0 and gate.current() == again + 1


class _DiesTogether:
    """A forkserver that dies while three processes' starts wait on it: each start fails as multiprocessing's does."""

    waiting = threading.Barrier(3, timeout=10)

    def __init__(self, *args, **kwargs):
        pass

    def start(self) -> None:
        _DiesTogether.waiting.wait()
        raise EOFError("unexpected EOF")


def test_uploads_that_saw_one_forkserver_die_pause_nothing(tmp_path, fresh_forkserver_starts, monkeypatch):
    monkeypatch.setattr(multiprocessing.get_context("forkserver"), "Process", _DiesTogether)
    _DiesTogether.waiting.reset()
    spec = load_kinds(PLUGINS)["test-compute"]
    path = tmp_path / "v.txt"
    path.write_bytes(b"1.5\n")
    said: list[BaseException] = []

    def upload() -> None:
        try:
            intake.read_upload_bounded(spec, StoredInput.from_path(path, "v.txt"), None, PLUGINS)
        except BaseException as error:  # noqa: BLE001 - what each upload met is the point
            said.append(error)

    uploads = [threading.Thread(target=upload) for _ in range(3)]
    for thread in uploads:
        thread.start()
    for thread in uploads:
        thread.join(10)
    assert len(said) == 3 and all(isinstance(error, INFRASTRUCTURE) for error in said), said
    # one death: the next start is tried at once (before: 3 failures, the next start 2 s later)
    assert fresh_forkserver_starts.failures == 1 and fresh_forkserver_starts.pause_left() == 0


_queued = queued_test_job


class _Killed:
    """A job process that ended by SIGKILL, as multiprocessing reports it."""

    def __init__(self, pid: int):
        self.pid, self.exitcode = pid, -signal.SIGKILL


def _child(job_id: uuid.UUID, **flags) -> processes._Running:
    worker = processes.worker_of(4_000_000)  # no such process
    return processes._Running(job_id, _Killed(4_000_000), None, worker, None, None, time.monotonic(), None,
                              "test-compute", **flags)


def test_a_hung_process_killed_after_the_sweep_requeued_its_job_starts_it_again_at_once_each_time(ctx):
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)  # queued again by the sweep, whose attempt it had held
    # before: the second such kill paused the job 1 s, the third 2 s ... as if its process died before its claim
    assert [dispatcher._judge_end(_child(job_id, abandoned=True), None) for _ in range(3)] == [True] * 3
    assert dispatcher._later == {} and dispatcher._unclaimed == {}


def test_deaths_before_the_claim_are_forgotten_at_any_other_end_and_at_stop(ctx):
    dispatcher = ProcessDispatcher(ctx, workers=1)
    job_id = _queued(ctx)
    for _ in range(2):
        dispatcher._judge_end(_child(job_id), None)
    assert dispatcher._unclaimed == {job_id: 2}
    dispatcher._judge_end(_child(job_id, killed_at_limit=True), None)  # before: kept for ever
    assert dispatcher._unclaimed == {}
    dispatcher._judge_end(_child(job_id), None)
    dispatcher.stop()
    assert dispatcher._unclaimed == {} and dispatcher._later == {}
    # the next death before its claim is a first again: back in line at once
    dispatcher._stopping.clear()
    assert dispatcher._judge_end(_child(job_id), None) is True


class _DiesAtStart:
    """A forkserver that dies at every start."""

    starts = 0

    def __init__(self, *args, **kwargs):
        pass

    def start(self) -> None:
        _DiesAtStart.starts += 1
        raise EOFError("unexpected EOF")


def test_an_upload_during_a_pause_is_refused_before_it_is_stored_and_told_when_to_come_back(
        tmp_path, fresh_forkserver_starts, monkeypatch):
    monkeypatch.setattr(forkserver, "ensure_running", lambda: None)  # no readers' forkserver started by the app
    monkeypatch.setattr(fresh_forkserver_starts, "backoff", Backoff(first=12.0, longest=30.0))
    monkeypatch.setattr(multiprocessing.get_context("forkserver"), "Process", _DiesAtStart)
    _DiesAtStart.starts = 0
    app = create_app(service_settings(tmp_path))
    files = app.state.jobs.ctx.files
    stored: list[str] = []
    put = files.put
    monkeypatch.setattr(files, "put", lambda key, *args, **kwargs: stored.append(key) or put(key, *args, **kwargs))
    with TestClient(app) as client:
        said = [client.post("/v1/test-compute/jobs", files={"file": ("v.txt", b"1.5\n")}) for _ in range(3)]
    assert [r.status_code for r in said] == [503] * 3 and _DiesAtStart.starts == 2
    # the first two reached a start (the second failure pauses the next for 12 s); the third stored nothing
    # (before: stored, then deleted) and is asked to come back when the pause ends (before: Retry-After 5)
    assert len(stored) == 2
    assert said[2].headers["retry-after"] == "12" and said[2].headers["content-type"] == "application/problem+json"
    assert "next start is tried in 12 s" in said[2].json()["detail"]


class _Popened:
    """A job process as the supervisor sees it, run as a plain command: ``sleep``."""

    def __init__(self, popen: subprocess.Popen):
        self.popen, self.pid = popen, popen.pid

    @property
    def exitcode(self) -> int | None:
        return self.popen.poll()

    def join(self, timeout: float) -> None:
        try:
            self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            pass

    def kill(self) -> None:
        self.popen.kill()


def test_the_ends_of_job_processes_killed_with_the_warm_parent_are_judged_though_an_enqueue_woke_the_wait(
        ctx, monkeypatch):
    monkeypatch.setattr(processes, "WARM_DEATH_SECONDS", 5.0)  # the wait ends once the end is judged, not then
    dispatcher = ProcessDispatcher(ctx, workers=1)
    dispatcher._thread = object()  # enqueue refuses while no supervisor runs; none is needed here
    job_id = _queued(ctx)
    receiver, sender = multiprocessing.Pipe(duplex=False)
    # its end reaches the supervisor a little after the wake-up of an enqueue
    popen = subprocess.Popen(["sleep", "0.05"], pass_fds=[sender.fileno()])
    sender.close()
    worker = processes.worker_of(popen.pid)
    dispatcher._running[job_id] = processes._Running(job_id, _Popened(popen), receiver, worker, None,
                                                     processes._started(popen.pid), time.monotonic(), None,
                                                     "test-compute")
    dispatcher._wake()
    began = time.monotonic()
    dispatcher._reap_killed_with_warm_parent()
    # before: the wake-up ended the wait at once, and this end was judged after the warm parent's start
    assert dispatcher._running == {} and time.monotonic() - began < 4.0
    assert list(dispatcher._waiting) == [(job_id, "")]  # judged: died before its claim, back in line at once
