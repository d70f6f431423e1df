"""What a process needs to run or serve jobs: settings, database, file store, registry."""

from __future__ import annotations

import os
import socket
from dataclasses import dataclass

from workers import registry
from workers.persistence import Database, FileStore, JobRepository
from workers.settings import Settings


@dataclass
class ServiceContext:
    settings: Settings
    db: Database
    repo: JobRepository
    files: FileStore

    @classmethod
    def create(cls, settings: Settings, *, migrate: bool = False) -> "ServiceContext":
        registry.load(settings.plugins)
        db = Database(settings.resolved_database_url)
        if migrate:
            db.migrate()
        return cls(settings=settings, db=db, repo=JobRepository(db.sessions, db.writing), files=FileStore(settings.resolved_artifact_dir))

    def close(self) -> None:
        self.db.dispose()


def worker_name(mode: str) -> str:
    return f"{mode}@{socket.gethostname()}:{os.getpid()}"
