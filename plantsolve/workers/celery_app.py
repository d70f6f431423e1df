"""Celery application for the scaled mode: ``plantsolve worker`` runs it.

Delivery is at-least-once (``acks_late`` + ``reject_on_worker_lost``): a message whose worker
died is delivered again, and the database lease and attempt fencing make that safe. The
attempt cap lives in the database, not in Celery's retry counter.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import uuid
from collections.abc import Callable
from contextlib import contextmanager
from functools import cached_property

from celery import Celery, bootsteps, signals
from celery.exceptions import SoftTimeLimitExceeded, TimeLimitExceeded
from kombu import Producer
from kombu.transport.redis import Channel as RedisChannel
from kombu.transport.redis import Transport as RedisTransport
from redis.asyncio import ConnectionPool
from redis.exceptions import ConnectionError as RedisConnectionError
from redis.exceptions import TimeoutError as RedisTimeoutError

from plantsolve.jobs.context import ServiceContext, worker_name
from plantsolve.jobs.dispatch import NoWorkers
from plantsolve.jobs.holds import DiskHold, held_countdown
from plantsolve.jobs.runner import fail_killed_at_hard_limit, run_job
from plantsolve.jobs.settings import JobSettings, get_job_settings
from plantsolve.solvers.kinds import load_kinds
from plantsolve.workers.logs import configure_logging
from plantsolve.workers.roll_call import Announcer, WorkerRoll, roll_client
from plantsolve.workers.sweeper import Sweeper
from plantsolve.workers.task_message import TaskMessageTemplate

log = logging.getLogger("plantsolve.celery")
PERSISTENT = 2  # the delivery mode send_task gives a task message


class _PublishingChannel(RedisChannel):
    """A Redis channel that publishes through one client of its connection pool: kombu's own builds a new client
    object for each message (``conn_or_acquire``), which costs a submission more than its database write. While
    ``recorder`` is set, a message's LPUSH is handed to it instead of the client: kombu builds the message, the
    caller sends it."""

    recorder = None

    @cached_property
    def _publisher(self):
        return self._create_client()

    @contextmanager
    def conn_or_acquire(self, client=None):
        yield client or self.recorder or self._publisher


class _Recorder:
    """Stands in for the Redis client while kombu puts a message onto the queue: keeps the LPUSH it makes."""

    def __init__(self):
        self.lpush_args: tuple[str, bytes] | None = None

    def lpush(self, key: str, payload: bytes) -> None:
        self.lpush_args = (key, payload)


class PublishingTransport(RedisTransport):
    """The Redis transport with :class:`_PublishingChannel`: the API's (it only publishes)."""

    Channel = _PublishingChannel


# How long an event loop's publish waits for Redis (connect, then the LPUSH's answer) before it gives up: the
# job's row is committed already, so the sweeper sends the message later
PUBLISH_SECONDS = 5.0


class _LoopPublisher:
    """One Redis connection of one event loop, that LPUSHes task messages: redis-py's connection, without its client
    (the client's lock, retry wrapper and per-command bookkeeping cost more than the round trip). One command at a
    time on the connection; bounded as a whole by the caller, without a socket timeout (redis-py's default: it
    wraps every write in a task of its own). A command that fails on the connection (it may have died with a
    restarted Redis) is sent once more at once, on a fresh connection, no backoff: the request is waiting."""

    def __init__(self, url: str, loop: asyncio.AbstractEventLoop):
        self.loop = loop
        self._pool = ConnectionPool.from_url(url, socket_connect_timeout=PUBLISH_SECONDS, socket_timeout=None)
        self._connection = self._pool.make_connection()
        self._turn = asyncio.Lock()

    async def lpush(self, key: str, payload: str, meanwhile: Callable[[], None] | None = None) -> None:
        """LPUSH ``payload`` onto ``key``; ``meanwhile()`` (which must not raise) is called once the command is
        written, before its answer is read: work that the caller needs done anyway then costs no wait of its own."""
        async with self._turn:
            try:
                await self._lpush(key, payload, meanwhile)
            except (RedisConnectionError, RedisTimeoutError):  # redis-py closed the connection: the next opens anew
                await self._lpush(key, payload, None)

    async def _lpush(self, key: str, payload: str, meanwhile: Callable[[], None] | None) -> None:
        connection = self._connection
        await connection.send_packed_command(connection.pack_command("LPUSH", key, payload), check_health=False)
        if meanwhile is not None:
            meanwhile()
        await connection.read_response()

    async def close(self) -> None:
        await self._connection.disconnect()
        await self._pool.disconnect()


def create_celery(settings: JobSettings, *, publisher: bool = False) -> Celery:
    """The Celery app; ``publisher``: a process that only sends tasks (the API), whose Redis messages go out
    through one client per pooled channel (:class:`PublishingTransport`)."""
    longest = max((float(settings.time_limits.get(spec.kind, spec.time_limit))
                   for spec in load_kinds(settings.plugins).values()), default=660.0)
    app = Celery("plantsolve", broker=settings.broker_url)
    if publisher and (settings.broker_url or "").split("://", 1)[0] in ("redis", "rediss"):
        app.conf.broker_transport = f"{__name__}:PublishingTransport"
    app.conf.update(
        task_acks_late=True,
        task_reject_on_worker_lost=True,
        worker_prefetch_multiplier=1,
        task_serializer="json",
        accept_content=["json"],
        result_serializer="json",
        task_ignore_result=True,
        # A message is re-delivered only after the visibility timeout: keep it above the
        # longest hard limit so a slow-but-alive job is never delivered twice by Redis.
        broker_transport_options={"visibility_timeout": int(longest * 2 + 60)},
        broker_connection_retry_on_startup=True,
        worker_hijack_root_logger=False,
    )
    app.steps["worker"].add(RollCallAfterReconnect)
    # a held job's task is retried for as long as the disk is low (max_retries None: no count of them)
    app.task(name="plantsolve.run_job", bind=True, max_retries=None)(_run_job_task)
    return app


class CeleryDispatcher:
    """Sends ``plantsolve.run_job(job_id)`` with the kind's time limits (scaled mode).

    Every message is Celery's own (``app.amqp.as_task_v2``: task protocol 2, the limits in its headers), put by one
    kombu producer straight onto the task queue (the nameless exchange routes by queue name; the worker declares
    the queue), on one broker connection kept open between messages. ``send_task`` did the same with a producer
    taken from a pool, the routing worked out, the queue declared and the publish wrapped in retries, for each
    message: most of a submission's CPU time. kombu builds the message and its Redis command (LPUSH of the encoded
    message onto the queue's list) once per kind, with ids that stand in for a job's; each job's
    message is that text with its own ids (:class:`~plantsolve.workers.task_message.TaskMessageTemplate`: the text
    kombu writes for them). The command is sent through the producer channel's Redis client (:meth:`enqueue`, any
    thread) or through a Redis connection of the running event loop (:meth:`enqueue_on_loop`, awaited: no thread). A
    publish that fails raises: the caller leaves the job to the sweeper, as before."""

    def __init__(self, ctx: ServiceContext):
        self.ctx = ctx
        self.celery = create_celery(ctx.settings, publisher=True)
        self._sweeper = Sweeper(ctx, self.enqueue, self.pending)
        self._queue = self.celery.conf.task_default_queue or "celery"
        self._opening = threading.Lock()  # the producer's connection is opened once, by one thread
        self._building = threading.Lock()  # a kombu channel serves one thread at a time (held for no I/O)
        self._connection = None
        self._producer = None
        self._templates: dict[str, TaskMessageTemplate] = {}  # by kind
        self._redis_url = ctx.settings.broker_url or ""
        self._loop_publisher: _LoopPublisher | None = None
        # the workers' roll call (workers/roll_call.py) lives in Redis: with another broker readiness cannot count them
        self._roll = WorkerRoll(roll_client(self._redis_url)) if self.enqueues_on_loop else None
        self.workers_apart = self._roll is not None

    def enqueue(self, job_id: uuid.UUID, kind: str) -> None:
        channel = self._open()
        key, payload = self._message(channel, job_id, kind)
        channel._publisher.lpush(key, payload)

    @property
    def enqueues_on_loop(self) -> bool:
        """Whether :meth:`enqueue_on_loop` may be awaited (a Redis broker)."""
        return self._redis_url.split("://", 1)[0] in ("redis", "rediss")

    async def enqueue_on_loop(self, job_id: uuid.UUID, kind: str, meanwhile: Callable[[], None] | None = None) -> None:
        """:meth:`enqueue` awaited on the running event loop: the same message, sent by the loop's own Redis
        connection (bounded by :data:`PUBLISH_SECONDS`); ``meanwhile()``, when given, runs while Redis answers (see
        :meth:`_LoopPublisher.lpush`). The producer's connection, when it is not open yet, is opened in a thread
        (once)."""
        channel = self._producer.channel if self._producer is not None else await asyncio.to_thread(self._open)
        key, payload = self._message(channel, job_id, kind)
        async with asyncio.timeout(PUBLISH_SECONDS):
            await self._publisher_of_loop().lpush(channel.global_keyprefix + key, payload, meanwhile)

    def _open(self):
        """The producer's channel, its broker connection opened if it is not (a failure drops it: the next message
        opens another)."""
        with self._opening:
            if self._producer is None:
                try:
                    self._connection = self.celery.connection_for_write()
                    self._producer = Producer(self._connection.default_channel, auto_declare=False)
                except Exception:
                    self._close_producer()
                    raise
            return self._producer.channel

    def _message(self, channel, job_id: uuid.UUID, kind: str) -> tuple[str, str]:
        """The task message of ``job_id`` as kombu puts it onto the queue: the Redis key and the encoded message."""
        template = self._templates.get(kind)
        if template is None:  # the kind's first message in this process (its limits are the settings', fixed)
            spec = self.ctx.spec(kind)
            limits = self.ctx.limits(spec) if spec is not None else None
            template = self._templates[kind] = TaskMessageTemplate.of(
                lambda job, task: self._built(channel, job, task, limits))
        return template.key, template.message(str(job_id), str(uuid.uuid4()), str(uuid.uuid4()))

    def _built(self, channel, job_id: str, task_id: str, limits: tuple[float, float] | None) -> tuple[str, str]:
        """The message kombu's producer builds for ``job_id`` as task ``task_id``: its Redis key and text."""
        soft_hard = {} if limits is None else {"soft_time_limit": limits[0], "time_limit": limits[1]}
        args = [job_id]
        # the representations the worker logs, given: Celery's own (saferepr, bounded for any argument) cost more
        message = self.celery.amqp.as_task_v2(task_id, "plantsolve.run_job", args=args, argsrepr=repr(args),
                                              kwargsrepr="{}", **soft_hard)
        recorder = _Recorder()
        with self._building:
            channel.recorder = recorder
            try:
                self._producer.publish(message.body, exchange="", routing_key=self._queue, headers=message.headers,
                                       serializer="json", delivery_mode=PERSISTENT, declare=(), retry=False,
                                       **message.properties)
            finally:
                channel.recorder = None
        return recorder.lpush_args

    def _publisher_of_loop(self) -> _LoopPublisher:
        """The running event loop's Redis publisher (connections belong to the loop that made them: another loop, such
        as a test client's next one, gets a publisher of its own; the old one's connection went with its loop)."""
        loop = asyncio.get_running_loop()
        if self._loop_publisher is None or self._loop_publisher.loop is not loop:
            self._loop_publisher = _LoopPublisher(self._redis_url, loop)
        return self._loop_publisher

    async def close_on_loop(self) -> None:
        """Close the running loop's Redis connection (at the end of the app's lifespan, on its loop)."""
        held, self._loop_publisher = self._loop_publisher, None
        if held is not None and held.loop is asyncio.get_running_loop():
            await held.close()

    def _close_producer(self) -> None:
        connection, self._connection, self._producer = self._connection, None, None
        if connection is not None:
            try:
                connection.release()
            except Exception:  # a connection that broke under the publish: nothing left to release
                log.debug("releasing the broken broker connection failed", exc_info=True)

    def pending(self) -> int | None:
        """Messages waiting in the broker's queue (Redis), or None when it cannot tell."""
        try:
            with self.celery.connection_for_read() as connection:
                client = getattr(connection.default_channel, "client", None)
                if client is None:
                    return None
                return int(client.llen(self.celery.conf.task_default_queue or "celery"))
        except Exception:  # an unreachable broker: the time rule alone decides
            log.warning("could not read the broker's queue length", exc_info=True)
            return None

    def ping(self) -> None:
        """Raises when the broker does not answer, :class:`NoWorkers` when it does but no worker has been heard from
        within ``WORKER_ALIVE_SECONDS`` (Redis: one command answers both; another broker is only reached)."""
        if self._roll is None:
            with self.celery.connection_for_write() as connection:
                connection.ensure_connection(max_retries=1, timeout=2)
            return
        window = self.ctx.settings.worker_alive_seconds
        if self._roll.alive(window) == 0:
            raise NoWorkers(f"no Celery worker has been heard from within {window:g} s")

    def start(self) -> None:
        self._sweeper.start()

    def stop(self) -> None:
        self._sweeper.stop()
        with self._opening:
            self._close_producer()
        if self._roll is not None:
            self._roll.client.close()


_ctx_lock = threading.Lock()
_ctx = None
_dispatcher = None
_disk_hold = None


def _worker_context():
    """One database context, dispatcher and disk hold per worker process, made on first use."""
    global _ctx, _dispatcher, _disk_hold
    with _ctx_lock:
        if _ctx is None:
            settings = get_job_settings()
            configure_logging(settings.log_format, settings.log_level)
            _ctx = ServiceContext.create(settings)
            _dispatcher = CeleryDispatcher(_ctx)
            _disk_hold = DiskHold(_ctx)
        return _ctx, _dispatcher


def _sent_again(ctx: ServiceContext, job_id: uuid.UUID) -> None:
    """The held job's message is sent again now (its retry): not one the sweeper is to send another of while the
    worker keeps it for its countdown, where the broker's queue length does not count it."""
    try:
        ctx.repo.mark_enqueued(job_id)
    except Exception as error:  # the database is away: the sweeper may send a second message, which runs once
        log.warning("job %s: its held message could not be marked sent (%s)", job_id, type(error).__name__)


def _run_job_task(task, job_id: str) -> str:
    ctx, dispatcher = _worker_context()
    job_uuid = uuid.UUID(job_id)
    if _disk_hold.holds():  # the job stays queued ('waiting: disk space low'); its task asks again after a while
        _sent_again(ctx, job_uuid)
        raise task.retry(countdown=held_countdown(task.request.retries or 0, ctx.settings.requeue_queued_after))
    outcome = run_job(
        ctx,
        job_uuid,
        worker=worker_name("celery"),
        requeue=dispatcher.enqueue,
        hard_limit_in_thread=False,  # Celery's own hard time limit kills the process
        time_limit_errors=(SoftTimeLimitExceeded,),
    )
    log.info("job %s: %s", job_id, outcome)
    return outcome


@signals.worker_init.connect
def _preload_kinds(**_kwargs) -> None:
    """In the worker's main process, before it forks its pool: every kind's solver imported once, shared by the
    pool processes (the kind map alone imports none; a process that only sends tasks, the API, never needs them)."""
    for spec in load_kinds(get_job_settings().plugins).values():
        spec.preload()


@signals.task_failure.connect
def _hard_time_limit(sender=None, exception=None, args=None, **_kwargs) -> None:
    """The pool killed a task's process at its hard time limit (a solver deaf even to the soft
    limit): fail the job now with a report, instead of letting the lease lapse and retrying a
    job that would hang again. Runs in the worker's main process."""
    if not isinstance(exception, TimeLimitExceeded) or not args:
        return
    ctx, _ = _worker_context()
    if fail_killed_at_hard_limit(ctx, uuid.UUID(str(args[0]))):
        log.warning("job %s killed at its hard time limit", args[0])


_announcer: Announcer | None = None


@signals.worker_ready.connect
def _join_the_roll(sender=None, **_kwargs) -> None:
    """In the worker's main process, once it consumes: say it is alive now and every ``WORKER_BEAT_SECONDS`` on the
    worker's own timer (the event loop that consumes: a worker whose loop is stuck falls silent too). Redis
    brokers only (the roll lives there)."""
    global _announcer
    settings = get_job_settings()
    if (settings.broker_url or "").split("://", 1)[0] not in ("redis", "rediss"):
        return
    _announcer = Announcer(WorkerRoll(roll_client(settings.broker_url)), worker_name("celery"),
                           settings.worker_alive_seconds)
    _announcer.beat()
    sender.timer.call_repeatedly(settings.worker_beat_seconds, _announcer.beat)


def _rejoin_the_roll(_worker, hub) -> None:
    """Put the roll call's beat back on the worker's timer as its event loop starts again. A worker whose broker
    connection broke (Redis restarted, its port closed a moment) empties its event loop's timer before it connects
    again, and ``worker_ready`` is not sent a second time: the worker went on running jobs while it beat no more, and
    readiness said ``workers: unavailable`` until it was restarted. The first start is left to :func:`_join_the_roll`
    (no announcer yet: the loop starts before the worker is ready)."""
    if _announcer is None or _announcer.stopped:
        return
    _announcer.beat()  # back on the roll now, not a beat later
    hub.timer.call_repeatedly(get_job_settings().worker_beat_seconds, _announcer.beat)


# A worker step: Celery calls each step's register_with_event_loop(worker, hub) whenever the event loop starts.
RollCallAfterReconnect = type("RollCallAfterReconnect", (bootsteps.StartStopStep,),
                              {"register_with_event_loop": staticmethod(_rejoin_the_roll)})


@signals.worker_shutting_down.connect
def _stop_beating(**_kwargs) -> None:
    """A shutdown was asked for (in the signal handler): a draining worker takes no new job, so it beats no more
    and drops out of the roll within the window, or at once when it has shut down."""
    if _announcer is not None:
        _announcer.stop()


@signals.worker_shutdown.connect
def _leave_the_roll(**_kwargs) -> None:
    if _announcer is not None:
        _announcer.withdraw()
