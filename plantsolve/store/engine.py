"""Engine and session factory for SQLite (embedded default) and PostgreSQL (scaled)."""

from __future__ import annotations

import sqlite3
import threading
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import OperationalError
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
    # connection, which the pre-ping would otherwise wait on for minutes) after ``statement`` in the kernel.
    bounds = {"connect_timeout": max(1, round(wait)), "tcp_user_timeout": int(statement * 1000),
              "keepalives": 1, "keepalives_idle": 5, "keepalives_interval": 2, "keepalives_count": 2,
              "options": f"-c statement_timeout={int(statement * 1000)} -c lock_timeout={int(wait * 1000)}"}
    given = set(parsed.query)
    # Connections above pool_size are closed on return; under a burst of submissions that
    # means a new PostgreSQL connection (several ms) per request, so keep the pool wide.
    return create_engine(url, pool_pre_ping=True, pool_size=24, max_overflow=16, pool_recycle=1800, pool_timeout=wait,
                         connect_args={k: v for k, v in bounds.items() if k not in given})


class WriteLock:
    """This process's SQLite write lock: a thread waits for it at most ``wait`` seconds, then its write fails as an
    unreachable database would (503), instead of queueing behind a write that itself waits on a locked file."""

    def __init__(self, wait: float):
        self.wait = wait
        self._lock = threading.Lock()

    def acquire(self, blocking: bool = True) -> bool:
        return self._lock.acquire(blocking, self.wait if blocking else -1)

    def release(self) -> None:
        self._lock.release()

    def __enter__(self) -> "WriteLock":
        if not self._lock.acquire(timeout=self.wait):
            raise OperationalError("(waiting for this process's write lock)", None,
                                   sqlite3.OperationalError(f"database is locked (waited {self.wait:g} s)"))
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
        # SQLite has one writer at a time and its busy handler backs off by sleeping
        # (1, 2, 5, 10 ... ms), which wrecks latency when the API and the job pool write at
        # once. Threads of this process therefore queue for writes on a lock instead; other
        # processes (a CLI run) still fall back on the busy timeout.
        self._write_lock = WriteLock(wait) if self.is_sqlite else None

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
        with self.engine.begin() as connection:
            if not self.is_sqlite:  # a migration may rewrite a large table: no request's statement bound
                connection.exec_driver_sql("SET LOCAL statement_timeout = 0")
            config.attributes["connection"] = connection
            command.upgrade(config, "head")

    def ping(self) -> None:
        """Raises unless the database can take a write now (within the bounds above): on SQLite the write lock is
        taken and released (a file locked by another process, or a read-only one, fails), on PostgreSQL a server
        that answers read-only (a standby) fails."""
        if self.is_sqlite:
            with self.writing(), self.engine.connect() as connection:
                connection.exec_driver_sql("BEGIN IMMEDIATE")
                connection.exec_driver_sql("ROLLBACK")
            return
        with self.engine.connect() as connection:
            if connection.execute(text("SHOW transaction_read_only")).scalar() == "on":
                raise OperationalError("SHOW transaction_read_only", None, RuntimeError("the database is read-only"))

    def dispose(self) -> None:
        self.engine.dispose()
