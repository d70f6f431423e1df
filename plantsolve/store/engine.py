"""Engine and session factory for SQLite (embedded default) and PostgreSQL (scaled)."""

from __future__ import annotations

import threading
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

MIGRATIONS_DIR = Path(__file__).parent / "migrations"


def _sqlite_pragmas(dbapi_connection, _record) -> None:
    # WAL lets readers run while a job result is written; the busy timeout makes concurrent
    # writers wait instead of failing; NORMAL sync is durable across process crashes in WAL.
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.close()


def make_engine(url: str) -> Engine:
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(
            url, connect_args={"check_same_thread": False, "timeout": 30}, pool_size=10, max_overflow=20
        )
        event.listen(engine, "connect", _sqlite_pragmas)
        return engine
    # Connections above pool_size are closed on return; under a burst of submissions that
    # means a new PostgreSQL connection (several ms) per request, so keep the pool wide.
    return create_engine(url, pool_pre_ping=True, pool_size=24, max_overflow=16, pool_recycle=1800)


class Database:
    """An engine plus its session factory; one per process and database URL."""

    def __init__(self, url: str):
        self.url = url
        self.engine = make_engine(url)
        self.sessions: sessionmaker[Session] = sessionmaker(self.engine, expire_on_commit=False)
        # SQLite has one writer at a time and its busy handler backs off by sleeping
        # (1, 2, 5, 10 ... ms), which wrecks latency when the API and the job pool write at
        # once. Threads of this process therefore queue for writes on a lock instead; other
        # processes (a CLI run) still fall back on the busy timeout.
        self._write_lock = threading.Lock() if self.is_sqlite else None

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
            config.attributes["connection"] = connection
            command.upgrade(config, "head")

    def ping(self) -> None:
        with self.engine.connect() as connection:
            connection.execute(text("SELECT 1"))

    def dispose(self) -> None:
        self.engine.dispose()
