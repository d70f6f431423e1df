"""Alembic environment: runs on the connection handed in by ``Database.migrate`` or, from
the ``alembic`` command line, on ``DATABASE_URL`` / the embedded default."""

from alembic import context

from plantsolve.store.models import Base

config = context.config
target_metadata = Base.metadata


def _run(connection) -> None:
    if connection.dialect.name == "sqlite":
        # batch mode copies a table and drops the old one, and with foreign keys on that drop deletes every row that
        # references it (a downgrade's rebuilt jobs table took every artifact row with it, ON DELETE CASCADE). Off
        # before the migration's first write (a PRAGMA in a transaction does nothing); whoever handed the connection
        # in turns it on again after the commit (Database.migrate), the command line's engine is dropped
        connection.exec_driver_sql("PRAGMA foreign_keys=OFF")
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        render_as_batch=connection.dialect.name == "sqlite",  # SQLite cannot ALTER most things
    )
    with context.begin_transaction():
        context.run_migrations()


connection = config.attributes.get("connection")
if connection is not None:
    _run(connection)
else:
    from plantsolve.store.engine import make_engine
    from plantsolve.store.settings import StoreSettings

    engine = make_engine(StoreSettings().resolved_database_url)
    with engine.begin() as conn:
        _run(conn)
