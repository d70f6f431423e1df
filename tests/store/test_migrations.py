"""Alembic migrations create exactly the tables the models describe, on SQLite and PostgreSQL."""

from __future__ import annotations

import sqlite3
import uuid
from datetime import datetime, timezone

import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.migration import MigrationContext
from sqlalchemy import inspect, text

from plantsolve.store import Database
from plantsolve.store.engine import MIGRATIONS_DIR
from plantsolve.store.models import Base


def _assert_upgraded_and_matching(db: Database) -> None:
    db.migrate()
    db.migrate()  # a second upgrade is a no-op
    with db.engine.connect() as connection:
        assert set(inspect(connection).get_table_names()) >= {"jobs", "artifacts", "blobs", "alembic_version"}
        context = MigrationContext.configure(connection)
        assert context.get_current_revision() == "0007"
        assert compare_metadata(context, Base.metadata) == []


def test_upgrade_empty_sqlite(tmp_path):
    db = Database(f"sqlite:///{tmp_path / 'fresh.db'}")
    try:
        _assert_upgraded_and_matching(db)
        with db.engine.connect() as connection:
            assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
    finally:
        db.dispose()


@pytest.mark.integration
def test_upgrade_empty_postgresql(pg_url):
    db = Database(pg_url)
    try:
        _assert_upgraded_and_matching(db)
        with db.engine.connect() as connection:  # out of line, uncompressed: a slice reads only its own chunks
            storage = connection.exec_driver_sql(
                "SELECT attstorage FROM pg_attribute WHERE attrelid = 'blobs'::regclass AND attname = 'data'").scalar()
        assert storage == "e"
    finally:
        db.dispose()


def _migrate(db: Database, revision: str, down: bool) -> None:
    """Alembic's own command on a connection of ``db``, as an operator's downgrade runs it."""
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR))
    with db.engine.connect() as connection:
        with connection.begin():
            config.attributes["connection"] = connection
            (command.downgrade if down else command.upgrade)(config, revision)
        connection.exec_driver_sql("PRAGMA foreign_keys=ON")
        connection.commit()


def _rows(db: Database) -> tuple[int, int]:
    with db.engine.connect() as connection:
        return (connection.exec_driver_sql("SELECT count(*) FROM jobs").scalar(),
                connection.exec_driver_sql("SELECT count(*) FROM artifacts").scalar())


def test_a_sqlite_downgrade_and_upgrade_keep_every_artifact_row(tmp_path):
    """Batch mode rebuilds the jobs table on SQLite (a dropped column, an altered type) and drops the old one; with
    foreign keys on, that drop deleted every artifact row (ON DELETE CASCADE) while the jobs survived."""
    db = Database(f"sqlite:///{tmp_path / 'kept.db'}")
    try:
        db.migrate()
        now = datetime.now(timezone.utc)
        with db.engine.begin() as connection:
            connection.execute(text(
                "INSERT INTO jobs (id, kind, status, attempt, max_attempts, progress, progress_message, input_kind, "
                "owner, body_hash, solver_version, created_at, callback_attempts, started_at) VALUES "
                "(:id, 'tube', 'succeeded', 1, 3, 1.0, '', 'json', '', 'h', 'v', :now, 0, :now)"),
                {"id": uuid.uuid4().hex, "now": now})
            job_id = connection.exec_driver_sql("SELECT id FROM jobs").scalar()
            connection.execute(text(
                "INSERT INTO artifacts (job_id, attempt, name, media_type, size, sha256, path, created_at) VALUES "
                "(:id, 1, 'result.json', 'application/json', 1, 's', 'p', :now)"), {"id": job_id, "now": now})
        assert _rows(db) == (1, 1)
        _migrate(db, "0001", down=True)  # through every revision's downgrade that rebuilds jobs (0007, 0004, 0002)
        assert _rows(db) == (1, 1)
        db.migrate()  # and up again: 0002 rebuilds jobs on its way
        assert _rows(db) == (1, 1)
        with db.engine.connect() as connection:
            assert connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1  # on again for the service
            assert connection.exec_driver_sql("PRAGMA foreign_key_check").all() == []
    finally:
        db.dispose()


def test_a_migration_whose_commit_fails_leaves_no_pooled_connection_without_foreign_keys(tmp_path):
    """A commit that fails can leave SQLite's transaction open, where turning foreign keys on again does nothing:
    that connection is closed, not pooled."""
    db = Database(f"sqlite:///{tmp_path / 'full.db'}")
    real_commit, failures = db.engine.dialect.do_commit, []

    def commit_failing_once(dbapi_connection):
        if not failures:
            failures.append(True)
            raise sqlite3.OperationalError("database or disk is full")
        return real_commit(dbapi_connection)

    db.engine.dialect.do_commit = commit_failing_once
    try:
        with pytest.raises(Exception, match="disk is full"):
            db.migrate()
        db.engine.dialect.do_commit = real_commit
        with db.engine.connect() as connection:
            assert connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
    finally:
        db.dispose()
