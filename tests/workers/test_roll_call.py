"""Scaled mode's readiness knows whether a Celery worker is there to run a job: each worker's main process writes
itself into a roll in Redis when it is ready and on each tick of its timer, and takes itself off when it shuts down;
``/readyz`` is 503 naming ``workers`` when nobody was heard from within ``WORKER_ALIVE_SECONDS`` (before: 200 while
every worker was dead, jobs 202-ed into a queue nobody read). On the real Redis, without starting Celery: the
worker's signal handlers are called as Celery calls them (tests/workers/test_integration_celery.py kills a real one).
"""

from __future__ import annotations

import dataclasses

import pytest
import redis
from celery import signals
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app, readiness
from plantsolve.jobs.context import worker_name
from plantsolve.jobs.settings import JobSettings, get_job_settings
from plantsolve.workers import celery_app
from plantsolve.workers.celery_app import CeleryDispatcher
from plantsolve.workers.roll_call import ROLL_KEY, Announcer, WorkerRoll, roll_client
from tests.conftest import service_settings

ALIVE = 15.0  # WORKER_ALIVE_SECONDS: the default
READY = {"database": "ok", "files": "ok", "disk": "ok", "jobs": "ok", "workers": "ok"}
NOBODY = {**READY, "workers": "unavailable"}


@pytest.fixture(scope="module")
def client(redis_url, tmp_path_factory):
    """The scaled API (SQLite suffices for the database part) on the test session's Redis database, jobs not run."""
    settings = service_settings(tmp_path_factory.mktemp("roll"), broker_url=redis_url, worker_alive_seconds=ALIVE)
    with TestClient(create_app(settings, run_jobs=False), raise_server_exceptions=False) as client:
        yield client


@pytest.fixture
def roll(redis_url):
    """The roll, empty (a worker of an integration test killed earlier in this session may have left its member)."""
    connection = redis.Redis.from_url(redis_url)
    connection.delete(ROLL_KEY)
    yield WorkerRoll(connection)
    connection.delete(ROLL_KEY)
    connection.close()


def _ready(client) -> tuple[int, dict]:
    response = client.get("/readyz")
    return response.status_code, response.json()["checks"]


def _server_time(connection: redis.Redis) -> float:
    seconds, micros = connection.time()
    return seconds + micros / 1e6


def test_a_workers_announcement_makes_readiness_ok_and_none_makes_it_503_naming_workers(client, roll):
    assert _ready(client) == (503, NOBODY)
    Announcer(roll, "celery@a:1", ALIVE).beat()
    assert _ready(client) == (200, READY)


def test_only_workers_heard_from_within_the_window_count(client, roll):
    now = _server_time(roll.client)
    roll.client.zadd(ROLL_KEY, {"celery@gone:1": now - ALIVE - 1, "celery@gone:2": now - 3600})  # SIGKILLed long ago
    assert roll.alive(ALIVE) == 0
    assert _ready(client) == (503, NOBODY)
    roll.client.zadd(ROLL_KEY, {"celery@late:1": now - ALIVE + 2})  # its last beat 13 s ago: still within 15 s
    assert roll.alive(ALIVE) == 1
    assert _ready(client) == (200, READY)
    # a beat drops the members older than the window: a dead worker leaves nothing behind
    Announcer(roll, "celery@b:2", ALIVE).beat()
    assert sorted(m.decode() for m in roll.client.zrange(ROLL_KEY, 0, -1)) == ["celery@b:2", "celery@late:1"]
    assert roll.alive(ALIVE) == 2


class _WorkerTimer:
    """The worker's timer as the roll call uses it (Celery's consumer hands its event loop's timer to worker_ready):
    what was asked to be called repeatedly, and how often."""

    def __init__(self):
        self.repeated: list[tuple[float, object]] = []

    def call_repeatedly(self, seconds, fun):
        self.repeated.append((seconds, fun))


class _Consumer:
    def __init__(self):
        self.timer = _WorkerTimer()


@pytest.fixture
def worker_env(monkeypatch, redis_url):
    """This process as a worker would be configured: BROKER_URL and a 0.5 s beat from the environment."""
    monkeypatch.setenv("BROKER_URL", redis_url)
    monkeypatch.setenv("WORKER_BEAT_SECONDS", "0.5")
    monkeypatch.setenv("WORKER_ALIVE_SECONDS", str(ALIVE))
    monkeypatch.setattr(celery_app, "_announcer", None)
    get_job_settings.cache_clear()
    yield
    get_job_settings.cache_clear()


@pytest.mark.usefixtures("worker_env")
def test_a_worker_joins_the_roll_when_ready_beats_on_its_timer_and_leaves_when_it_shuts_down(client, roll):
    consumer = _Consumer()
    signals.worker_ready.send(sender=consumer)
    member = worker_name("celery")
    joined = roll.client.zscore(ROLL_KEY, member)
    assert joined is not None
    assert _ready(client) == (200, READY)
    [(seconds, beat)] = consumer.timer.repeated
    assert seconds == 0.5
    beat()  # the timer's tick: announced again, later by Redis's clock
    assert roll.client.zscore(ROLL_KEY, member) > joined
    # SIGTERM: a draining worker takes no new job, so it beats no more...
    signals.worker_shutting_down.send(sender="celery@test", sig="SIGTERM", how="Warm", exitcode=0)
    roll.client.zadd(ROLL_KEY, {member: _server_time(roll.client) - ALIVE - 1})  # ...and its last beat ages out
    beat()
    assert roll.alive(ALIVE) == 0
    roll.client.zadd(ROLL_KEY, {member: _server_time(roll.client)})
    # once it has shut down it takes itself off the roll at once
    signals.worker_shutdown.send(sender=None)
    assert roll.client.zscore(ROLL_KEY, member) is None
    assert _ready(client) == (503, NOBODY)


def test_a_broker_that_does_not_answer_makes_both_parts_unavailable(client):
    ctx = client.app.state.ctx
    away = dataclasses.replace(ctx, settings=ctx.settings.model_copy(update={"broker_url": "redis://127.0.0.1:9/0"}))
    status = readiness(away, CeleryDispatcher(away))  # nothing listens on port 9
    assert (status.status, status.checks) == ("unavailable", {**READY, "jobs": "unavailable", "workers": "unavailable"})


def test_a_beat_that_cannot_reach_redis_is_logged_and_the_worker_goes_on(caplog):
    away = Announcer(WorkerRoll(roll_client("redis://127.0.0.1:9/0")), "celery@a:1", ALIVE)  # nothing on port 9
    away.beat()  # on the worker's event loop: raising there would stop the worker's timer
    away.withdraw()
    assert [r.getMessage().split(":")[0] for r in caplog.records if r.name == "plantsolve.celery"] == [
        "could not tell Redis this worker is alive", "could not take this worker off the roll"]


def test_a_window_no_longer_than_a_beat_is_refused():
    with pytest.raises(ValueError, match="WORKER_BEAT_SECONDS"):
        JobSettings(_env_file=None, worker_beat_seconds=5.0, worker_alive_seconds=5.0)
