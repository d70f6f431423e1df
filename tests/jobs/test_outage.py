"""A database outage costs no work: a lease that lapsed while nobody could heartbeat is extended, not
swept; the attempt that was running keeps its claim and stores its result; no second solve."""

from __future__ import annotations

import threading
import time
from datetime import timedelta

import pytest
from sqlalchemy import update
from sqlalchemy.exc import OperationalError

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import sweep_once
from plantsolve.jobs.lifecycle import QUEUED, RUNNING, SUCCEEDED
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from plantsolve.store.models import Job, utcnow
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings
from tests.jobs.test_runner import Recorder


def _away(*args, **kwargs):
    raise OperationalError("SELECT 1", {}, ConnectionRefusedError("database is away"))


def _lapse(ctx, job_id) -> None:
    with ctx.db.sessions() as session:
        session.execute(update(Job).where(Job.id == job_id).values(lease_until=utcnow() - timedelta(seconds=5)))
        session.commit()


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, lease_seconds=0.8, heartbeat_seconds=0.1,
                                                     sweep_seconds=0.1), migrate=True)
    yield context
    context.close()


def test_a_sweep_after_an_outage_extends_a_lapsed_lease_instead_of_requeueing(ctx):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=0.8, worker="w") == 1
    _lapse(ctx, job_id)
    sweep_once(ctx, lambda *a: None, after_outage=True)
    job = ctx.repo.get(job_id)
    assert (job.status, job.attempt) == (RUNNING, 1)
    assert ctx.repo.heartbeat(job_id, 1, lease_seconds=0.8)  # the attempt still owns the job
    _lapse(ctx, job_id)  # a lease that lapses with the database up: the worker is gone
    sweep_once(ctx, lambda *a: None)
    assert ctx.repo.get(job_id).status == QUEUED


def test_the_pass_after_a_failed_one_extends_the_leases(ctx, monkeypatch):
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(job_id, lease_seconds=0.8, worker="w") == 1
    sweeper = Sweeper(ctx, lambda *a: None)
    lapsed = ctx.repo.lapsed
    monkeypatch.setattr(ctx.repo, "lapsed", _away)
    assert not sweeper.run_pass()
    _lapse(ctx, job_id)
    monkeypatch.setattr(ctx.repo, "lapsed", lapsed)
    assert sweeper.run_pass()
    assert ctx.repo.get(job_id).status == RUNNING
    _lapse(ctx, job_id)
    assert sweeper.run_pass()  # no outage before this one: the lapsed lease is swept
    assert ctx.repo.get(job_id).status == QUEUED


def test_a_running_job_survives_an_outage_longer_than_its_lease_and_is_solved_once(ctx, tmp_path, monkeypatch):
    markers = tmp_path / "runs"
    body = f'{{"values": [1, 2], "seconds": 2.4, "marker_dir": "{markers}"}}'.encode()
    dispatcher = Recorder()
    job_id = JobService(ctx, dispatcher).submit_json("test-compute", body, None).job.id
    sweeper = Sweeper(ctx, dispatcher.enqueue)
    sweeper.start()
    outcome: list[str] = []
    runner = threading.Thread(target=lambda: outcome.append(
        run_job(ctx, job_id, worker="w", requeue=lambda *a: None)))
    runner.start()
    time.sleep(0.4)
    saved = {name: getattr(ctx.repo, name) for name in ("heartbeat", "set_progress", "lapsed")}
    for name in saved:  # the database goes away for twice the lease
        monkeypatch.setattr(ctx.repo, name, _away)
    time.sleep(1.6)
    for name, method in saved.items():
        monkeypatch.setattr(ctx.repo, name, method)
    runner.join(timeout=30)
    sweeper.stop()
    job = ctx.repo.get(job_id)
    assert outcome == [SUCCEEDED]
    assert (job.status, job.attempt) == (SUCCEEDED, 1)
    assert [h["outcome"] for h in job.attempts] == ["succeeded"]
    assert len(list(markers.iterdir())) == 1  # solved once
    assert job_id not in dispatcher.enqueued[1:]  # never sent again
