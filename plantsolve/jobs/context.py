"""What a process needs to run or serve jobs: settings, the store and the map of solver kinds."""

from __future__ import annotations

import functools
import os
import socket
from dataclasses import dataclass
from typing import Mapping

from plantsolve.jobs.settings import JobSettings
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.kinds import load_kinds
from plantsolve.store import BlobStore, Database, JobRepository, LocalBlobStore, Store


@dataclass
class ServiceContext:
    settings: JobSettings
    store: Store
    kinds: Mapping[str, SolverSpec]

    @classmethod
    def create(cls, settings: JobSettings, *, migrate: bool | str = False) -> "ServiceContext":
        """The built-in kinds plus those of the ``PLUGINS`` modules; an import error is raised."""
        return cls(settings=settings, store=Store.open(settings, migrate=migrate), kinds=load_kinds(settings.plugins))

    @property
    def db(self) -> Database:
        return self.store.db

    @property
    def repo(self) -> JobRepository:
        return self.store.repo

    @property
    def files(self) -> BlobStore:
        """Uploads, large JSON requests, artifacts and spooled results (BLOB_STORE)."""
        return self.store.files

    @property
    def spool(self) -> LocalBlobStore:
        """This machine's folder (ARTIFACT_DIR): where a result waits when the blob store cannot take it."""
        return self.store.spool

    def spec(self, kind: str) -> SolverSpec | None:
        return self.kinds.get(kind)

    def preload(self) -> None:
        """Import every kind's functions now: a job process pays its imports once, at start, and no job pays them
        within its time limit. (The map itself imports none of them; a process that only lists the kinds, the CLI's
        help or the API, never does.)"""
        for spec in self.kinds.values():
            spec.preload()

    def limits(self, spec: SolverSpec) -> tuple[float, float]:
        """(soft, hard) time limit of a kind: the settings' override, else the kind's own."""
        hard = float(self.settings.time_limits.get(spec.kind, spec.time_limit))
        soft = float(self.settings.soft_time_limits.get(spec.kind, min(spec.soft_time_limit, hard)))
        return min(soft, hard), hard

    def close(self) -> None:
        self.store.close()


def worker_name(mode: str, pid: int | None = None) -> str:
    """``mode@host:pid`` of this process (or of ``pid`` on this host); the host carries its process-id namespace
    (``host~4026531836``) where one can be read, since containers may share a host name (a fixed compose
    ``hostname:``, host networking) while their pids are each their own."""
    return f"{mode}@{socket.gethostname()}{_pid_namespace()}:{os.getpid() if pid is None else pid}"


@functools.cache
def _pid_namespace() -> str:
    try:
        return f"~{os.stat('/proc/self/ns/pid').st_ino}"
    except OSError:
        return ""
