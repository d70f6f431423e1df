"""The Celery workers' roll call in Redis (scaled mode): who is there to run a job.

Each worker's main process writes its member (``celery@<host>:<pid>``) into one sorted set, scored with the Redis
server's clock, when it is ready and every ``WORKER_BEAT_SECONDS`` after; it stops when it is asked to shut down
(a draining worker takes no new job) and takes itself off when it has shut down. Readiness counts the members
heard from within ``WORKER_ALIVE_SECONDS`` in one command, which is also its check that the broker answers. A
worker killed outright (SIGKILL, a lost host, a stuck event loop) writes no more and drops out after that window.

The scores are Redis's own time (``TIME`` inside the script), not a worker's: workers on other hosts with clocks
apart from the API's count the same. Each announcement also drops the members older than the window, so workers
that died leave nothing behind.
"""

from __future__ import annotations

import logging

from redis import Redis
from redis.backoff import NoBackoff
from redis.exceptions import RedisError
from redis.retry import Retry

log = logging.getLogger("plantsolve.celery")

ROLL_KEY = "plantsolve:workers"
# How long one roll-call command waits for Redis (connect, then the answer); one retry on a fresh connection (the
# kept one may have died with a restarted Redis), so at most twice this.
ROLL_SECONDS = 2.0

# KEYS[1] the roll; ARGV[1] the member, ARGV[2] the window in seconds
_ANNOUNCE = """
local now = redis.call('TIME')
local t = tonumber(now[1]) + tonumber(now[2]) / 1000000
redis.call('ZREMRANGEBYSCORE', KEYS[1], '-inf', '(' .. (t - tonumber(ARGV[2])))
return redis.call('ZADD', KEYS[1], t, ARGV[1])
"""
# KEYS[1] the roll; ARGV[1] the window in seconds
_COUNT = """
local now = redis.call('TIME')
local t = tonumber(now[1]) + tonumber(now[2]) / 1000000
return redis.call('ZCOUNT', KEYS[1], t - tonumber(ARGV[1]), '+inf')
"""


def roll_client(url: str) -> Redis:
    """A Redis client of the broker's URL for the roll call, bounded by :data:`ROLL_SECONDS`."""
    return Redis.from_url(url, socket_connect_timeout=ROLL_SECONDS, socket_timeout=ROLL_SECONDS,
                          retry=Retry(NoBackoff(), 1))


class WorkerRoll:
    """The roll of one Redis: ``announce`` and ``withdraw`` (workers), ``alive`` (readiness)."""

    def __init__(self, client: Redis, key: str = ROLL_KEY):
        self.client = client
        self.key = key

    def announce(self, member: str, window_seconds: float) -> None:
        self.client.eval(_ANNOUNCE, 1, self.key, member, repr(window_seconds))

    def withdraw(self, member: str) -> None:
        self.client.zrem(self.key, member)

    def alive(self, window_seconds: float) -> int:
        """Workers heard from within the last ``window_seconds`` (by Redis's clock): one round trip."""
        return int(self.client.eval(_COUNT, 1, self.key, repr(window_seconds)))


class Announcer:
    """One worker process's part in the roll call: :meth:`beat` on start and on each tick of the worker's timer,
    :meth:`stop` when a shutdown is asked for (no more beats: called from a signal handler, so it only sets a flag),
    :meth:`withdraw` once the worker has shut down. A beat that fails is logged and the next one tries again (the
    worker's own broker connection tells the same story)."""

    def __init__(self, roll: WorkerRoll, member: str, window_seconds: float):
        self.roll = roll
        self.member = member
        self.window_seconds = window_seconds
        self.stopped = False

    def beat(self) -> None:
        if self.stopped:
            return
        try:
            self.roll.announce(self.member, self.window_seconds)
        except RedisError as error:  # Redis away: readiness says so too; this worker beats again at the next tick
            log.warning("could not tell Redis this worker is alive: %s: %s", type(error).__name__, error)

    def stop(self) -> None:
        self.stopped = True

    def withdraw(self) -> None:
        self.stopped = True
        try:
            self.roll.withdraw(self.member)
        except RedisError as error:  # it drops out of the roll after the window instead
            log.warning("could not take this worker off the roll: %s: %s", type(error).__name__, error)
