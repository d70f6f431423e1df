"""Restarts of the forkserver and of job processes, as seen once (runtime58's review): one forkserver death seen by
several callers counts once."""

from __future__ import annotations

import multiprocessing
import threading

import pytest

from plantsolve.jobs import intake
from plantsolve.jobs.errors import INFRASTRUCTURE
from plantsolve.jobs.intake import ForkserverStarts
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import load_kinds

PLUGINS = ("tests.support.kinds",)


def test_a_forkserver_failure_seen_by_several_callers_counts_once():
    gate = ForkserverStarts(first_pause=1.0, longest=30.0)
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
