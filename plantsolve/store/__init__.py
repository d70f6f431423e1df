"""The store: the database that is the source of truth for jobs, and the artifact file store.

Both the app (submissions, reads) and the workers (claims, results) use it; it imports neither
of them, nor any solver.
"""

from __future__ import annotations

from dataclasses import dataclass

from plantsolve.store.engine import Database
from plantsolve.store.files import FileStore
from plantsolve.store.repository import JobRepository
from plantsolve.store.sessions import SessionRepository
from plantsolve.store.settings import StoreSettings


@dataclass
class Store:
    """One process's handle on the store: database, job repository, artifact files, dashboard sessions."""

    db: Database
    repo: JobRepository
    files: FileStore
    sessions: SessionRepository

    @classmethod
    def open(cls, settings: StoreSettings, *, migrate: bool = False) -> "Store":
        db = Database(settings.resolved_database_url)
        if migrate:
            db.migrate()
        return cls(db=db, repo=JobRepository(db.sessions, db.writing), files=FileStore(settings.resolved_artifact_dir),
                   sessions=SessionRepository(db.sessions, db.writing))

    def close(self) -> None:
        self.db.dispose()


__all__ = ["Database", "FileStore", "JobRepository", "SessionRepository", "Store", "StoreSettings"]
