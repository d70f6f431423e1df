"""PostgreSQL connections of an event loop: the submit path's write awaited on the loop, without a thread.

A write in a worker thread costs the hop to the thread and back and a wake-up of each thread per round trip; an
``AsyncConnection`` (psycopg) is awaited by the event loop itself, which serves other requests meanwhile. The
bounds are those of the engine's connections (:mod:`plantsolve.store.engine`): the same connection parameters
(connect, statement, lock and idle-in-transaction timeouts, TCP keepalives and user timeout), each round trip
bounded by ``statement + wait`` on the client (a black-holed link: the connection is closed and the call raises),
a connection idle :data:`~plantsolve.store.engine.PING_IDLE_SECONDS` pinged with the bound ``wait`` before use (a
ping that fails drops every idle connection), and a request waits at most ``wait`` for a free connection.

The pool is this small class rather than ``psycopg_pool``: its connections belong to one event loop, and a test
client that runs each request on a loop of its own must find them made anew on the next loop (the sockets of a loop
that is gone are closed), which a pool opened on one loop with its own background tasks does not do.
"""

from __future__ import annotations

import asyncio
import functools
import time
from contextlib import asynccontextmanager
from typing import Any, AsyncIterator

from sqlalchemy.exc import DBAPIError

from plantsolve.store import engine as engine_module

# connections at most, as the engine's pool (pool_size + max_overflow)
SIZE = 40


@functools.cache
def bounded_async_connection_class() -> type:
    """``BoundedAsyncConnection``: the async twin of :func:`~plantsolve.store.engine.bounded_connection_class`, each
    wait for the server at most ``round_trip_seconds`` (then the connection is closed and the call raises
    ``OperationalError``). A wait given its own timeout keeps it. Bounded by a timeout, never by cancelling the
    wait: psycopg answers a cancelled wait by asking the server to cancel the query, which over a dead link waits
    too."""
    import psycopg

    class BoundedAsyncConnection(psycopg.AsyncConnection):
        round_trip_seconds: float | None = None

        async def wait(self, gen, *args, **kwargs):
            bound = self.round_trip_seconds
            if bound is None or args[1:] or kwargs.get("timeout") is not None:
                return await super().wait(gen, *args, **kwargs)
            started = time.monotonic()
            try:
                return await super().wait(gen, *args, **kwargs, timeout=bound)
            except psycopg.OperationalError:
                if time.monotonic() - started < bound:
                    raise
                await self.close()
                raise psycopg.OperationalError(f"no answer from the database within {bound:g} s (the connection "
                                               "is closed)") from None

    return BoundedAsyncConnection


class LoopConnections:
    """Autocommit ``AsyncConnection``\\ s to the database of ``engine``, for the event loop that uses them."""

    def __init__(self, engine, *, wait: float, statement: float, size: int = SIZE):
        self.dialect = engine.dialect
        _args, params = engine.dialect.create_connect_args(engine.url)
        self.params = {**engine_module.postgres_bounds(engine.url.render_as_string(hide_password=False), wait=wait,
                                                       statement=statement), **params}
        self.wait, self.statement, self.size = wait, statement, size
        self._idle: list[tuple[Any, float]] = []  # (connection, when it came back), the newest last
        self._loop: asyncio.AbstractEventLoop | None = None
        self._slots: asyncio.Semaphore | None = None

    async def run(self, statement: str, params: tuple, *, fetch: bool = False) -> list[tuple] | None:
        """Execute one statement (its own transaction) on a connection of this loop; ``fetch``: its rows. A driver
        error comes back as SQLAlchemy's exception of its class (an ``IntegrityError`` for a taken unique key),
        marked invalidated when the connection broke (then it is not used again), as from the engine."""
        connection = None
        try:
            async with self.connection() as connection:
                cursor = await connection.execute(statement, params)
                return await cursor.fetchall() if fetch else None
        except self.dialect.loaded_dbapi.Error as error:
            invalidated = connection is None or self.dialect.is_disconnect(error, connection, None)
            raise DBAPIError.instance(statement, params, error, self.dialect.loaded_dbapi.Error,
                                      connection_invalidated=invalidated, dialect=self.dialect) from error

    @asynccontextmanager
    async def connection(self) -> AsyncIterator[Any]:
        """A connection of this loop, in autocommit, for one request; given back afterwards unless it broke (or was
        left inside a transaction). Raises ``TimeoutError`` when none is free within ``wait``."""
        slots = self._bind()
        if slots.locked():
            await asyncio.wait_for(slots.acquire(), self.wait)
        else:
            await slots.acquire()
        connection = None
        try:
            connection = await self._checkout()
            yield connection
        finally:
            if connection is not None:
                self._give_back(connection)
            slots.release()

    def _bind(self) -> asyncio.Semaphore:
        loop = asyncio.get_running_loop()
        if loop is not self._loop:  # another loop (the last one ended): its connections cannot serve this one
            self.close()
            self._loop, self._slots = loop, asyncio.Semaphore(self.size)
        return self._slots

    async def _checkout(self):
        while self._idle:
            connection, returned = self._idle.pop()
            if time.monotonic() - returned < engine_module.PING_IDLE_SECONDS:
                return connection
            if await self._answers(connection):
                return connection
            self.close()  # the server or the link is gone: every idle connection is made anew
        connection = await bounded_async_connection_class().connect(autocommit=True, **self.params)
        connection.round_trip_seconds = self.statement + self.wait
        return connection

    async def _answers(self, connection) -> bool:
        connection.round_trip_seconds = self.wait
        try:
            await connection.execute("SELECT 1")
            return True
        except Exception:
            _finish(connection)
            return False
        finally:
            connection.round_trip_seconds = self.statement + self.wait

    def _give_back(self, connection) -> None:
        if connection.closed or connection.broken or connection.info.transaction_status.name != "IDLE":
            _finish(connection)
        else:
            self._idle.append((connection, time.monotonic()))

    def close(self) -> None:
        """Close the idle connections (at once: no round trip, no event loop needed)."""
        idle, self._idle = self._idle, []
        for connection, _ in idle:
            _finish(connection)


def _finish(connection) -> None:
    """Close a connection's socket now (``AsyncConnection.close`` is a coroutine of the loop the connection
    belongs to, which may be gone)."""
    try:
        connection.pgconn.finish()
    except Exception:
        pass
