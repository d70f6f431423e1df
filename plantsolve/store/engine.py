"""Engine and session factory for SQLite (embedded default) and PostgreSQL (scaled)."""

from __future__ import annotations

import functools
import os
import select
import sqlite3
import threading
import time
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Callable

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import InvalidatePoolError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

MIGRATIONS_DIR = Path(__file__).parent / "migrations"


# How long one write waits for the database before the request answers 503 (DATABASE_WAIT_SECONDS): SQLite's busy
# timeout and this process's write lock, PostgreSQL's connect timeout and a pooled connection's checkout.
WAIT_SECONDS = 3.0
# How long one PostgreSQL statement may run, and unacknowledged data may wait on a dead link (DATABASE_STATEMENT_SECONDS).
STATEMENT_SECONDS = 10.0


def _sqlite_pragmas(wait: float):
    def pragmas(dbapi_connection, _record) -> None:
        # WAL lets readers run while a job result is written; the busy timeout makes concurrent writers wait a
        # short, stated time, then fail (503) instead of hanging; NORMAL sync is durable across process crashes in
        # WAL.
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={int(wait * 1000)}")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()
    return pragmas


def make_engine(url: str, *, wait: float = WAIT_SECONDS, statement: float = STATEMENT_SECONDS) -> Engine:
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": wait}, pool_size=10,
                               max_overflow=20, pool_timeout=wait)
        event.listen(engine, "connect", _sqlite_pragmas(wait))
        return engine
    # Every request is bounded: a connect that gets no answer (a black-holed link) gives up after ``wait``, a
    # statement after ``statement`` on the server, and unacknowledged data (a link that died under a pooled
    # connection) after ``statement`` in the kernel. Where the kernel sees nothing wrong (the server's host, or a
    # proxy between, takes the bytes and never answers; a server that hangs) the client bounds each round trip
    # itself (bounded_connection_class). The server's side of such a link: a session left inside a transaction
    # (its client gone mid-write) ends after statement + wait, so its row locks do not stall every later write.
    # Connections above pool_size are closed on return; under a burst of submissions that
    # means a new PostgreSQL connection (several ms) per request, so keep the pool wide.
    engine = create_engine(url, pool_size=24, max_overflow=16, pool_recycle=1800, pool_timeout=wait,
                           connect_args=postgres_bounds(url, wait=wait, statement=statement))
    _bound_round_trips(engine, wait=wait, statement=statement)
    return engine


def postgres_bounds(url: str, *, wait: float, statement: float) -> dict[str, object]:
    """The connection parameters that bound every PostgreSQL request (see :func:`make_engine`), less those the URL
    sets itself."""
    bounds = {"connect_timeout": max(1, round(wait)), "tcp_user_timeout": int(statement * 1000),
              "keepalives": 1, "keepalives_idle": 5, "keepalives_interval": 2, "keepalives_count": 2,
              "options": f"-c statement_timeout={int(statement * 1000)} -c lock_timeout={int(wait * 1000)} "
                         f"-c idle_in_transaction_session_timeout={int((statement + wait) * 1000)}"}
    given = set(make_url(url).query)
    return {k: v for k, v in bounds.items() if k not in given}


# A pooled connection that was idle this long is pinged before a request uses it (one that came back a moment
# ago is not: under load a ping per request cost a round trip and a fifth of a submission's CPU time, unless the
# server has spoken on it meanwhile: see spoke_while_idle)
PING_IDLE_SECONDS = 0.25


def spoke_while_idle(fd: int) -> bool:
    """Whether the socket ``fd`` of an idle PostgreSQL connection has something to read. Nothing was asked, so it
    is most often the server's farewell before it closed the connection (its backend ended by
    ``pg_terminate_backend``, an idle-session timeout, a pooler or a failover): the connection must not carry a
    request. One system call, no round trip."""
    poller = select.poll()
    poller.register(fd, select.POLLIN | select.POLLERR | select.POLLHUP)
    return bool(poller.poll(0))


@functools.cache
def bounded_connection_class() -> type:
    """``BoundedConnection``: a psycopg connection whose every wait for the server (``Connection.wait``, where each
    round trip of psycopg waits) lasts at most ``round_trip_seconds``; then the connection is closed and the call
    raises ``OperationalError``: SQLAlchemy sees a closed connection (a disconnect), drops it from the pool, and
    the request answers 503. The bound is above the server's statement timeout, so that a slow statement ends with
    the server's own error first. (A function: psycopg is the [scaled] extra, imported for PostgreSQL only.)"""
    import psycopg

    class BoundedConnection(psycopg.Connection):
        round_trip_seconds: float | None = None

        def wait(self, gen, *args, **kwargs):
            bound = self.round_trip_seconds
            if bound is None or args[1:] or kwargs.get("timeout") is not None:  # a caller's own bound wins
                return super().wait(gen, *args, **kwargs)
            started = time.monotonic()
            try:
                return super().wait(gen, *args, **kwargs, timeout=bound)
            except psycopg.OperationalError:
                if time.monotonic() - started < bound:
                    raise
                self.close()
                raise psycopg.OperationalError(f"no answer from the database within {bound:g} s (the connection "
                                               "is closed)") from None

    return BoundedConnection


def _bound_round_trips(engine: Engine, *, wait: float, statement: float) -> None:
    """Connections made as ``BoundedConnection`` (a round trip waits at most ``statement + wait``); a pooled
    connection idle for :data:`PING_IDLE_SECONDS`, or one the server has spoken on meanwhile (:func:`spoke_while_idle`),
    is pinged first with the bound ``wait`` (a ping that gets no answer in time, or fails, drops the pool's
    connections and the checkout connects anew: SQLAlchemy's pessimistic disconnect handling, with a bounded ping)."""

    @event.listens_for(engine, "do_connect")
    def connect(_dialect, record, cargs, cparams):
        connection = bounded_connection_class().connect(*cargs, **cparams)
        connection.round_trip_seconds = statement + wait
        record.info["returned"] = time.monotonic()
        return connection

    @event.listens_for(engine, "checkin")
    def returned(dbapi_connection, record) -> None:
        record.info["returned"] = time.monotonic()

    @event.listens_for(engine, "checkout")
    def ping_after_idle(dbapi_connection, record, *_proxy) -> None:
        if time.monotonic() - record.info.get("returned", 0.0) < PING_IDLE_SECONDS and \
                not (dbapi_connection.closed or spoke_while_idle(dbapi_connection.fileno())):
            return
        bound = dbapi_connection.round_trip_seconds
        dbapi_connection.round_trip_seconds = wait
        try:
            engine.dialect.do_ping(dbapi_connection)
        except Exception as error:
            # the server or the link is gone: every pooled connection is made anew (on its next checkout)
            raise InvalidatePoolError(f"a pooled connection did not answer a ping: {error}") from error
        finally:
            dbapi_connection.round_trip_seconds = bound


class SQLiteFile:
    """The SQLite file this process opened first, known by its device and inode. A data directory removed or replaced
    under a running service (``rm -rf var``, a temporary-file cleaner, a volume unmounted) leaves the open connections
    writing into a file that no longer has a name: a submission would be answered 202 and vanish with the process,
    and a new connection would make a new, empty file at the path. So every write, every new connection and the
    readiness probe first check that the path still names that file; if not, the database counts as unreachable (503,
    ``/readyz`` 503) until a restart opens the file now at the path."""

    def __init__(self, path: Path):
        self.path = path
        self.known: tuple[int, int] | None = None

    def _identity(self) -> tuple[int, int] | None:
        try:
            found = os.stat(self.path)
        except OSError:  # gone, its folder replaced by a file, no longer ours to read, a stale network handle
            return None
        return found.st_dev, found.st_ino

    def learn(self) -> None:
        if self.known is None:
            self.known = self._identity()

    def check(self) -> None:
        if self.known is not None and self._identity() != self.known:
            raise sqlite3.OperationalError(
                f"the database file {self.path} was removed or replaced while the service ran; nothing more is written "
                "to the old one: restart the service to use the file now at that path")


class WriteLock:
    """This process's SQLite write lock: a thread waits for it at most ``wait`` seconds, then its write fails as an
    unreachable database would (503), instead of queueing behind a write that itself waits on a locked file. Taken,
    it runs ``check`` (:meth:`SQLiteFile.check`): a write to a file that lost its name fails the same way."""

    def __init__(self, wait: float, check: Callable[[], None] | None = None):
        self.wait = wait
        self.check = check
        self._lock = threading.Lock()

    def acquire(self, blocking: bool = True) -> bool:
        """Whether the lock was taken (False too when ``check`` fails: the caller's fallback takes it the way that
        raises)."""
        if not self._lock.acquire(blocking, self.wait if blocking else -1):
            return False
        try:
            self._check()
        except OperationalError:
            self._lock.release()
            return False
        return True

    def release(self) -> None:
        self._lock.release()

    def _check(self) -> None:
        if self.check is not None:
            try:
                self.check()
            except sqlite3.OperationalError as error:
                raise OperationalError("(checking the database file)", None, error) from None

    def __enter__(self) -> "WriteLock":
        if not self._lock.acquire(timeout=self.wait):
            raise OperationalError("(waiting for this process's write lock)", None,
                                   sqlite3.OperationalError(f"database is locked (waited {self.wait:g} s)"))
        try:
            self._check()
        except OperationalError:
            self._lock.release()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self._lock.release()


class Database:
    """An engine plus its session factory; one per process and database URL."""

    def __init__(self, url: str, *, wait: float = WAIT_SECONDS, statement: float = STATEMENT_SECONDS):
        self.url = url
        self.wait = wait
        self.engine = make_engine(url, wait=wait, statement=statement)
        self.sessions: sessionmaker[Session] = sessionmaker(self.engine, expire_on_commit=False)
        database = make_url(url).database if self.is_sqlite else None
        if database and database.startswith("file:"):  # a URI filename (?uri=true): its path, without its query
            database = database.removeprefix("file:").split("?", 1)[0] or None
        self.file = SQLiteFile(Path(database).resolve()) if database and database != ":memory:" else None
        if self.file is not None:
            self._watch_file(self.file)
        # SQLite has one writer at a time and its busy handler backs off by sleeping
        # (1, 2, 5, 10 ... ms), which wrecks latency when the API and the job pool write at
        # once. Threads of this process therefore queue for writes on a lock instead; other
        # processes (a CLI run) still fall back on the busy timeout.
        self._write_lock = WriteLock(wait, self.file.check if self.file else None) if self.is_sqlite else None

    def _watch_file(self, file: SQLiteFile) -> None:
        """The first connection learns the file; a later one is refused when the path names another file or none
        (SQLite would make a new, empty one)."""
        event.listen(self.engine, "do_connect", lambda _dialect, _record, _cargs, _cparams: file.check())
        event.listen(self.engine, "connect", lambda _dbapi_connection, _record: file.learn())

    def writing(self) -> AbstractContextManager:
        """Context for one write transaction: serialised in-process on SQLite, free on PostgreSQL."""
        return self._write_lock if self._write_lock is not None else nullcontext()

    @property
    def is_sqlite(self) -> bool:
        return self.engine.dialect.name == "sqlite"

    def migrate(self) -> None:
        """Upgrade the schema to the newest Alembic revision."""
        from alembic import command
        from alembic.config import Config

        config = Config()
        config.set_main_option("script_location", str(MIGRATIONS_DIR))
        with self.engine.connect() as connection:
            try:
                with connection.begin():
                    dbapi_connection = connection.connection.dbapi_connection
                    bound = getattr(dbapi_connection, "round_trip_seconds", None)
                    if not self.is_sqlite:  # a migration may rewrite a large table: no request's statement bound
                        connection.exec_driver_sql("SET LOCAL statement_timeout = 0")
                        dbapi_connection.round_trip_seconds = None
                    try:
                        config.attributes["connection"] = connection
                        command.upgrade(config, "head")
                    finally:
                        if bound is not None:
                            dbapi_connection.round_trip_seconds = bound
            finally:
                if self.is_sqlite:
                    # the migration turned foreign keys off for its table copies (migrations/env.py): on again, and
                    # where that did nothing (a PRAGMA inside a transaction a failed commit left open) the connection
                    # is closed instead of given back to the pool, whose next one opens with them on
                    try:
                        connection.rollback()
                        connection.exec_driver_sql("PRAGMA foreign_keys=ON")
                        on = connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
                        connection.commit()
                    except Exception:
                        on = False
                    if not on:
                        connection.invalidate()

    def ping(self) -> None:
        """Raises unless the database can take a write now (within the bounds above): on SQLite the write lock is
        taken and released (a file locked by another process, or a read-only one, fails), on PostgreSQL a server
        that answers read-only (a standby) fails, and so does a jobs table whose rows cannot be written within the
        database wait: the lock every UPDATE takes is asked for and given back (another session's lock that blocks
        writes, a migration's CREATE INDEX, made heartbeats wait and fail while reads went on). Writers do not
        block that lock, so the check waits on nothing else."""
        if self.is_sqlite:
            with self.writing(), self.engine.connect() as connection:
                connection.exec_driver_sql("BEGIN IMMEDIATE")
                connection.exec_driver_sql("ROLLBACK")
            return
        with self.engine.connect() as connection, connection.begin() as transaction:
            connection.exec_driver_sql(f"SET LOCAL lock_timeout = {max(1, int(self.wait * 1000))}")
            read_only, migrated = connection.execute(text(
                "SELECT current_setting('transaction_read_only'), to_regclass('jobs') IS NOT NULL")).one()
            if read_only == "on":
                raise OperationalError("SHOW transaction_read_only", None, RuntimeError("the database is read-only"))
            if migrated:
                connection.exec_driver_sql("LOCK TABLE jobs IN ROW EXCLUSIVE MODE")
            transaction.rollback()

    def dispose(self) -> None:
        self.engine.dispose()
