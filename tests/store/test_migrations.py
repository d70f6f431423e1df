"""Alembic migrations create exactly the tables the models describe, on SQLite and PostgreSQL."""

from __future__ import annotations

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from plantsolve.store import Database
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
