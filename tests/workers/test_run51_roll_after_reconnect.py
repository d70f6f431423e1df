"""A Celery worker whose broker connection broke (Redis restarted) beats on the roll again once it has connected again.

Celery empties its event loop's timer before it reconnects (``celery.worker.loops.asynloop``) and sends
``worker_ready`` only once, so the roll call's beat, put on that timer when the worker was ready, was gone: the
worker ran jobs while ``/readyz`` said ``workers: unavailable`` until it was restarted. Here the worker's signal and
its event loop's restart are driven as Celery drives them, on the real Redis and Celery's own timer class.
"""

from __future__ import annotations

import pytest
import redis
from celery import signals
from kombu.asynchronous.timer import Timer

from plantsolve.jobs.context import worker_name
from plantsolve.jobs.settings import JobSettings, get_job_settings
from plantsolve.workers import celery_app
from plantsolve.workers.roll_call import ROLL_KEY


class _Consumer:
    def __init__(self, timer: Timer):
        self.timer = timer


class _Hub:
    def __init__(self, timer: Timer):
        self.timer = timer


@pytest.fixture
def roll(monkeypatch, redis_url):
    monkeypatch.setenv("BROKER_URL", redis_url)
    monkeypatch.setenv("WORKER_BEAT_SECONDS", "0.5")
    monkeypatch.setattr(celery_app, "_announcer", None)
    get_job_settings.cache_clear()
    connection = redis.Redis.from_url(redis_url)
    connection.delete(ROLL_KEY)
    yield connection
    connection.delete(ROLL_KEY)
    connection.close()
    get_job_settings.cache_clear()


def _worker_steps() -> list:
    app = celery_app.create_celery(JobSettings(_env_file=None, broker_url="redis://127.0.0.1:9/0"))
    return list(app.steps["worker"])


def test_the_beat_is_back_on_the_timer_after_the_event_loop_restarts(roll):
    timer = Timer()
    member = worker_name("celery")
    # the loop's first start comes before the worker is ready: the ready signal puts the beat on
    for step in _worker_steps():
        step(None).register_with_event_loop(None, _Hub(timer))
    assert timer.queue == []
    signals.worker_ready.send(sender=_Consumer(timer))
    assert len(timer.queue) == 1
    joined = roll.zscore(ROLL_KEY, member)
    assert joined is not None
    timer.clear()  # Redis went away: Celery empties the timer before it connects again
    roll.delete(ROLL_KEY)  # and a restarted Redis without persistence has no roll
    for step in _worker_steps():  # connected again: the worker's steps are registered with the new loop
        step(None).register_with_event_loop(None, _Hub(timer))
    assert len(timer.queue) == 1  # beating again, once per beat
    assert roll.zscore(ROLL_KEY, member) is not None  # on the roll at once
    roll.delete(ROLL_KEY)
    timer.queue[0].entry()  # the timer's next tick
    assert roll.zscore(ROLL_KEY, member) is not None


def test_a_worker_shutting_down_is_not_put_back_on_the_roll(roll):
    timer = Timer()
    signals.worker_ready.send(sender=_Consumer(timer))
    signals.worker_shutting_down.send(sender="celery@test", sig="SIGTERM", how="Warm", exitcode=0)
    timer.clear()
    roll.delete(ROLL_KEY)
    for step in _worker_steps():
        step(None).register_with_event_loop(None, _Hub(timer))
    assert timer.queue == [] and roll.zscore(ROLL_KEY, worker_name("celery")) is None
