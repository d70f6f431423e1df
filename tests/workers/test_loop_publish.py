"""The task message sent on the event loop (``CeleryDispatcher.enqueue_on_loop``, a redis.asyncio client) is the
one the thread's publish sends and the one Celery's own ``send_task`` sends, as a worker reads it; a submission
whose message Redis did not take is answered 202 all the same, left unmarked, and the sweeper sends it."""

from __future__ import annotations

import asyncio
import base64
import json
import uuid

import pytest
import redis
from fastapi.testclient import TestClient
from sqlalchemy import text

from plantsolve.app.main import create_app
from plantsolve.jobs.context import ServiceContext
from plantsolve.workers.celery_app import CeleryDispatcher
from tests.conftest import service_settings

pytestmark = pytest.mark.integration

SUBMIT = ("/v1/test-compute/jobs", {"values": [1.5, 2.5]})


def _as_worker_reads(raw: bytes) -> dict:
    """A message on the queue without what differs between any two (task id, delivery tag), the body decoded."""
    message = json.loads(raw)
    body = json.loads(base64.b64decode(message.pop("body")))
    headers = {k: v for k, v in message.pop("headers").items() if k not in ("id", "root_id")}
    properties = {k: v for k, v in message.pop("properties").items() if k not in ("correlation_id", "delivery_tag")}
    return {"body": body, "headers": headers, "properties": properties, **message}


@pytest.fixture
def dispatcher(tmp_path, redis_url):
    client = redis.Redis.from_url(redis_url)
    client.delete("celery")
    ctx = ServiceContext.create(service_settings(tmp_path, broker_url=redis_url))
    dispatcher = CeleryDispatcher(ctx)
    yield dispatcher, client
    dispatcher.stop()
    ctx.close()
    client.delete("celery")


def test_the_loops_message_is_the_threads_and_celerys_own(dispatcher):
    dispatcher, client = dispatcher
    assert dispatcher.enqueues_on_loop
    job_id = uuid.uuid4()
    dispatcher.enqueue(job_id, "test-compute")

    called = []

    async def on_loop():
        # ``meanwhile`` runs once, after the command is written, while Redis answers
        await dispatcher.enqueue_on_loop(job_id, "test-compute", meanwhile=lambda: called.append(len(called)))
        await dispatcher.close_on_loop()

    asyncio.run(on_loop())
    assert called == [0]
    soft, hard = dispatcher.ctx.limits(dispatcher.ctx.spec("test-compute"))
    dispatcher.celery.send_task("plantsolve.run_job", args=[str(job_id)], soft_time_limit=soft, time_limit=hard)
    celerys, on_loop, in_thread = (json.loads(raw) for raw in client.lrange("celery", 0, -1))  # LPUSH: newest first
    assert _as_worker_reads(json.dumps(on_loop)) == _as_worker_reads(json.dumps(in_thread))
    assert on_loop["headers"]["id"] != in_thread["headers"]["id"]  # a task id of its own
    ours, theirs = _as_worker_reads(json.dumps(on_loop)), _as_worker_reads(json.dumps(celerys))
    assert ours["body"] == theirs["body"] == [[str(job_id)], {}, {"callbacks": None, "errbacks": None, "chain": None,
                                                                  "chord": None}]
    for name in ("task", "timelimit", "argsrepr", "kwargsrepr", "lang", "retries", "eta", "expires", "group",
                 "parent_id", "origin" if "origin" in theirs["headers"] else "task"):
        assert ours["headers"][name] == theirs["headers"][name], name
    assert ours["headers"]["timelimit"] == [hard, soft]
    # Celery's names a reply queue (for results, which these tasks do not keep)
    assert {**ours["properties"], "reply_to": None} == {**theirs["properties"], "reply_to": None}
    assert {k: v for k, v in ours.items() if k not in ("body", "headers", "properties")} == \
        {k: v for k, v in theirs.items() if k not in ("body", "headers", "properties")}


@pytest.mark.parametrize("kind", ["test-compute", "test-hang"])  # two kinds' time limits: two templates
def test_a_jobs_message_is_the_one_kombu_builds_for_its_ids_byte_for_byte(dispatcher, monkeypatch, kind):
    dispatcher, _ = dispatcher
    channel = dispatcher._open()
    messages = {job_id: dispatcher._message(channel, job_id, kind) for job_id in (uuid.uuid4(), uuid.uuid4())}
    for job_id, (key, text) in messages.items():
        message = json.loads(text)
        task_id, tag = message["headers"]["id"], message["properties"]["delivery_tag"]
        assert len({task_id, tag, str(job_id)}) == 3
        monkeypatch.setattr(channel, "_next_delivery_tag", lambda: tag)
        # kombu's producer, as the dispatcher used it for every message before: the same key and text
        assert dispatcher._built(channel, str(job_id), task_id, dispatcher.ctx.limits(dispatcher.ctx.spec(kind))) == \
            (key, text)
        assert json.loads(base64.b64decode(message["body"]))[0] == [str(job_id)]
        assert message["headers"]["argsrepr"] == repr([str(job_id)])
        assert message["headers"]["root_id"] == message["properties"]["correlation_id"] == task_id
    assert len({json.loads(text)["headers"]["id"] for _, text in messages.values()}) == 2


def test_a_message_redis_did_not_take_is_sent_by_the_sweeper(tmp_path, pg_url, redis_url):
    queue = redis.Redis.from_url(redis_url)
    queue.delete("celery")
    settings = service_settings(tmp_path, database_url=pg_url, broker_url=redis_url, sweep_seconds=3600.0)
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        dispatcher = client.app.state.dispatcher
        assert client.post(*SUBMIT[:1], json=SUBMIT[1]).status_code == 202  # the kind's first: in a thread
        client.portal.call(dispatcher.close_on_loop)
        dispatcher._redis_url = "redis://127.0.0.1:1/0"  # nothing listens there
        response = client.post(*SUBMIT[:1], json=SUBMIT[1])
        assert response.status_code == 202
        job_id = response.json()["id"]
        with client.app.state.ctx.db.engine.connect() as connection:
            assert connection.execute(text("SELECT enqueued_at FROM jobs WHERE id = :id"), {"id": job_id}).scalar() is None
        assert [json.loads(base64.b64decode(json.loads(raw)["body"]))[0] for raw in queue.lrange("celery", 0, -1)] \
            != [[job_id]]
        assert dispatcher._sweeper.run_pass()
        sent = [json.loads(base64.b64decode(json.loads(raw)["body"]))[0][0] for raw in queue.lrange("celery", 0, -1)]
        assert sent.count(job_id) == 1  # (the session's database may hold other jobs left unsent: sent too)
    queue.delete("celery")
