"""PostgreSQL connections of an event loop: the submit path's INSERT and the status read awaited on the loop, without
a thread.

A statement run in a worker thread costs the hop to the thread and back and a wake-up of each thread per round trip;
a connection of the event loop is awaited by the loop itself, which serves other requests meanwhile. The driver is
asyncpg: its protocol lives in the loop (no reader registered and removed per round trip) and encodes and decodes in
C, which halves the CPU of the submit's INSERT and cuts the status read's to a third next to psycopg's
``AsyncConnection`` (measured in the API process on the jobs row, 1,500 of each, interleaved: INSERT 0.22 vs 0.43 ms,
read 0.04 vs 0.12 ms). The statements are the ones the engine's connections send (the row written and the record
read are the same: tests/store/test_loop_connections.py); JSON goes in and out as the standard library writes and
reads it, as through psycopg.

The bounds are those of the engine's connections (:mod:`plantsolve.store.engine`): the server's statement, lock and
idle-in-transaction timeouts; a connect that gets no answer gives up after ``wait``; each round trip waits at most
``statement + wait`` on the client (a black-holed link: the connection is closed and the call raises); a connection
the server closed while it was idle is dropped, not used (the loop read its farewell); one
idle :data:`~plantsolve.store.engine.PING_IDLE_SECONDS` is pinged with the bound ``wait`` before use (a ping that
fails drops every idle connection); a request waits at most ``wait`` for a free connection. A driver error comes
back as SQLAlchemy's exception of its class (an ``IntegrityError`` for a taken unique key; a connection that broke,
or did not answer in time, as a disconnect), so that callers handle it as one from the engine.

The pool is this small class: its connections belong to one event loop, and a test client that runs each request on
a loop of its own must find them made anew on the next loop (those of a loop that is gone are dropped).
"""

from __future__ import annotations

import asyncio
import functools
import importlib.util
import json
import time
from typing import Any

from sqlalchemy.exc import IntegrityError, OperationalError, ProgrammingError

from plantsolve.store import engine as engine_module

# connections at most (beside the engine's pool, which then serves the other requests: 24 + 16 overflow); requests
# beyond it wait for one, at most ``wait``
SIZE = 24
# SQLSTATE classes of a server error that says the database cannot serve now (503), not that the request is wrong:
# connection exception, invalid authorization, no such database (a connect refused, as psycopg's OperationalError),
# insufficient resources, operator intervention (a cancelled statement, a shutdown), system error; and
# lock_not_available (the lock timeout)
UNAVAILABLE = ("08", "28", "3D", "53", "57", "58", "55P03")


# the parameters of a database URL that asyncpg reads as libpq does; a URL with any other (``options``,
# ``connect_timeout``, ``keepalives`` …) is left to the engine's connections alone
URL_PARAMETERS = {"sslmode", "sslrootcert", "sslcert", "sslkey", "sslpassword", "application_name",
                  "target_session_attrs"}


def available(engine) -> bool:
    """Whether an event loop can have connections of its own to ``engine``'s database: PostgreSQL, a URL whose
    parameters asyncpg reads as libpq does, and asyncpg installed (the [scaled] extra). Otherwise the thread's path
    serves."""
    return engine.dialect.name == "postgresql" and set(engine.url.query) <= URL_PARAMETERS \
        and importlib.util.find_spec("asyncpg") is not None


@functools.cache
def _asyncpg():
    import asyncpg  # the [scaled] extra: imported for PostgreSQL only

    return asyncpg


class LoopConnections:
    """asyncpg connections to the database of ``engine`` (its URL), for the event loop that uses them."""

    def __init__(self, engine, *, wait: float, statement: float, size: int = SIZE):
        self.dsn = engine.url.set(drivername="postgresql").render_as_string(hide_password=False)
        self.server_settings = {"statement_timeout": str(int(statement * 1000)), "lock_timeout": str(int(wait * 1000)),
                                "idle_in_transaction_session_timeout": str(int((statement + wait) * 1000))}
        self.wait, self.statement, self.size = wait, statement, size
        self._idle: list[tuple[Any, float]] = []  # (connection, when it came back), the newest last
        self._loop: asyncio.AbstractEventLoop | None = None
        self._slots: asyncio.Semaphore | None = None

    async def execute(self, statement: str, *args: Any) -> None:
        """Run one statement (its own transaction: committed when this returns)."""
        await self._run("execute", statement, args)

    async def fetch(self, statement: str, *args: Any) -> list[Any]:
        """The rows of one query (each a record: by position or by name). A query that met a connection the server
        had just ended (its farewell came with the answer) is asked once more, on another connection: a read is safe
        to repeat, and the database is there."""
        try:
            return await self._run("fetch", statement, args)
        except OperationalError as error:
            if not _ended_by_server(error.orig):
                raise
        return await self._run("fetch", statement, args)

    async def _run(self, method: str, statement: str, args: tuple) -> Any:
        """A connection of this loop runs the statement, and is given back afterwards unless the statement failed on
        it (any error but the server's own answer closes it). No connection free within ``wait``: a disconnect."""
        asyncpg = _asyncpg()
        slots = self._bind()
        try:
            if slots.locked():
                await asyncio.wait_for(slots.acquire(), self.wait)
            else:
                await slots.acquire()
        except TimeoutError as error:
            raise OperationalError(statement, args, error, connection_invalidated=True) from error
        connection = None
        try:
            connection = await self._checkout()
            result = await getattr(connection, method)(statement, *args)
        except asyncpg.PostgresError as error:  # the server's answer: the connection is fine
            state = error.sqlstate or ""
            kind = IntegrityError if state.startswith("23") else \
                OperationalError if state.startswith(UNAVAILABLE) else ProgrammingError
            raise kind(statement, args, error) from error
        except (OSError, asyncpg.InterfaceError, asyncpg.InternalClientError) as error:  # timeouts are OSErrors too
            connection = _terminated(connection)
            raise OperationalError(statement, args, error, connection_invalidated=True) from error
        except BaseException:
            connection = _terminated(connection)
            raise
        finally:
            if connection is not None and not connection.is_closed():
                self._idle.append((connection, time.monotonic()))
            slots.release()
        return result

    def _bind(self) -> asyncio.Semaphore:
        loop = asyncio.get_running_loop()
        if loop is not self._loop:  # another loop (the last one ended): its connections cannot serve this one
            self.close()
            self._loop, self._slots = loop, asyncio.Semaphore(self.size)
        return self._slots

    async def _checkout(self):
        while self._idle:
            connection, returned = self._idle.pop()
            if connection.is_closed():  # the server ended it meanwhile (this loop has read its farewell)
                _terminate(connection)
                continue
            if time.monotonic() - returned < engine_module.PING_IDLE_SECONDS:
                return connection
            try:
                await connection.execute("SELECT 1", timeout=self.wait)
                return connection
            except Exception:  # the server or the link is gone: every idle connection is made anew
                _terminate(connection)
                self.close()
        connection = await _asyncpg().connect(self.dsn, timeout=self.wait, command_timeout=self.statement + self.wait,
                                              server_settings=self.server_settings)
        try:
            await connection.set_type_codec("json", schema="pg_catalog", encoder=json.dumps, decoder=json.loads)
        except BaseException:
            _terminate(connection)
            raise
        return connection

    def close(self) -> None:
        """Close the idle connections (at once: no round trip, no event loop needed)."""
        idle, self._idle = self._idle, []
        for connection, _ in idle:
            _terminate(connection)


def _ended_by_server(error: BaseException | None) -> bool:
    """Whether a driver error says the server ended the connection (``pg_terminate_backend``, an idle-session
    timeout, a pooler): not a timeout, not a server that does not answer."""
    asyncpg = _asyncpg()
    return isinstance(error, (asyncpg.ConnectionDoesNotExistError, asyncpg.InternalClientError,
                              asyncpg.AdminShutdownError)) or \
        (isinstance(error, asyncpg.InterfaceError) and "closed" in str(error))


def _terminated(connection) -> None:
    """None, once ``connection`` (if any) is closed: a connection a request failed on is not given back."""
    if connection is not None:
        _terminate(connection)


def _terminate(connection) -> None:
    """Close a connection at once, without a round trip (its loop may be gone: then its socket goes with it)."""
    try:
        connection.terminate()
    except Exception:
        pass
