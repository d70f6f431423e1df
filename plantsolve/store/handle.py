"""One process's handle on the store (database, job repository, blobs, dashboard sessions, spool)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from plantsolve.store.blobs import BlobStore, LocalBlobStore
from plantsolve.store.blobs_database import DatabaseBlobStore
from plantsolve.store.blobs_s3 import S3BlobStore
from plantsolve.store.disk import check_free_space
from plantsolve.store.engine import Database
from plantsolve.store.loop_connections import LoopConnections
from plantsolve.store.loop_connections import available as loop_connections_available
from plantsolve.store.models import Base
from plantsolve.store.repository import JobRepository
from plantsolve.store.sessions import SessionRepository
from plantsolve.store.settings import StoreSettings


@dataclass
class Store:
    """One process's handle on the store: database, job repository, blobs (``files``), dashboard sessions, and
    ``spool``: this machine's folder, where a computed result waits when the blob store cannot take it either
    (the PostgreSQL back-end during a database outage)."""

    db: Database
    repo: JobRepository
    files: BlobStore
    sessions: SessionRepository
    spool: LocalBlobStore
    loop_connections: LoopConnections | None = None
    min_free_disk_bytes: int = 0

    @classmethod
    def open(cls, settings: StoreSettings, *, migrate: bool | str = False) -> "Store":
        """``migrate``: True upgrades the schema (Alembic); ``"scratch"`` creates it on a new throwaway database."""
        db = Database(settings.resolved_database_url, wait=settings.database_wait_seconds,
                      statement=settings.database_statement_seconds)
        if migrate == "scratch":  # lives as long as one process (a CLI run): no history to keep, no Alembic to replay
            Base.metadata.create_all(db.engine)
        elif migrate:
            db.migrate()
        local = LocalBlobStore(settings.resolved_artifact_dir)
        # SQLite writes one transaction at a time: concurrent submissions share one (see store/writer.py)
        # PostgreSQL: an event loop's own connections, for the submissions it writes and the statuses it reads itself
        # (made on first use)
        loop_connections = LoopConnections(db.engine, wait=db.wait, statement=settings.database_statement_seconds) \
            if loop_connections_available(db.engine) else None
        repo = JobRepository(db.sessions, db.writing, group_commit=db.is_sqlite, loop_connections=loop_connections)
        return cls(db=db, repo=repo, files=open_blob_store(settings, db, local),
                   sessions=SessionRepository(db.sessions, db.writing), spool=local, loop_connections=loop_connections,
                   min_free_disk_bytes=settings.min_free_disk_bytes)

    def check_disk(self) -> None:
        """Raise :class:`~plantsolve.store.disk.DiskLow` when a disk this process writes to (``ARTIFACT_DIR``, the
        SQLite file's folder) has less than ``MIN_FREE_DISK_BYTES`` free."""
        folders: dict[str, Path] = {"ARTIFACT_DIR": self.spool.root}
        if self.db.file is not None:
            folders["database"] = self.db.file.path.parent
        check_free_space(folders, self.min_free_disk_bytes)

    def close(self) -> None:
        self.repo.close()
        self.db.dispose()
        if self.loop_connections is not None:
            self.loop_connections.close()


def open_blob_store(settings: StoreSettings, db: Database, local: LocalBlobStore) -> BlobStore:
    kind = settings.resolved_blob_store
    if kind == "postgres":
        return DatabaseBlobStore(db)
    if kind == "s3":
        if not settings.s3_bucket:
            raise ValueError("BLOB_STORE=s3 needs S3_BUCKET")
        return S3BlobStore(settings.s3_bucket, endpoint_url=settings.s3_endpoint_url, region=settings.s3_region)
    return local

