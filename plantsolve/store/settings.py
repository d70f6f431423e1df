"""Where the store keeps its data, read from the environment (or a ``.env`` file).

Settings are layered by room, each layer adding what its room needs: :class:`StoreSettings`
(here) → :class:`plantsolve.jobs.settings.JobSettings` (queue and runner) →
:class:`plantsolve.app.settings.AppSettings` (HTTP). All read the same environment, so one
``.env`` configures every process. With nothing set the service runs on the embedded default:
a SQLite file under ``./var``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


class StoreSettings(BaseSettings):
    model_config = SettingsConfigDict(env_file=".env", extra="ignore")

    data_dir: Path = Field(
        default=Path("var"),
        description="Directory for the embedded SQLite file and, by default, artifacts and uploads.",
    )
    database_url: str | None = Field(
        default=None,
        description="SQLAlchemy URL. Unset: sqlite:///<DATA_DIR>/plantsolve.db (WAL mode). "
        "Scaled: postgresql+psycopg://user@host/db.",
    )
    artifact_dir: Path | None = Field(
        default=None, description="The local blob store's folder (uploads, artifacts, spooled results), and where a "
        "result waits when no other blob store takes it. Unset: <DATA_DIR>/artifacts."
    )
    blob_store: Literal["local", "postgres", "s3"] | None = Field(
        default=None,
        description="Where uploads, artifacts and spooled results live: 'local' (files under ARTIFACT_DIR: one machine "
        "or a shared volume), 'postgres' (a table in the jobs' database), 's3' (S3_BUCKET). Unset: 'postgres' when "
        "DATABASE_URL is PostgreSQL, else 'local'.",
    )
    database_wait_seconds: float = Field(
        default=3.0, gt=0, le=60,
        description="How long a write waits for the database before the request answers 503: SQLite's busy timeout "
        "(a file another process holds locked) and this process's write lock; PostgreSQL's connect timeout, lock "
        "timeout and pooled-connection checkout.")
    database_statement_seconds: float = Field(
        default=10.0, gt=0, le=600,
        description="PostgreSQL: how long one statement may run (statement_timeout) and data may wait unacknowledged "
        "on a dead link (tcp_user_timeout), so a black-holed database answers 503 in seconds.")
    min_free_disk_bytes: int = Field(
        default=512 * 2**20, ge=0,
        description="Free space below which the service is not ready (/readyz 503 naming 'disk'), on the disk of "
        "ARTIFACT_DIR and of the SQLite file; 0: not checked.")
    s3_bucket: str | None = Field(default=None, description="BLOB_STORE=s3: the bucket (it must exist).")
    s3_endpoint_url: str | None = Field(
        default=None, description="BLOB_STORE=s3: the server's URL when it is not AWS (MinIO, Ceph, Garage …).")
    s3_region: str | None = Field(default=None, description="BLOB_STORE=s3: the region (else boto3's default).")

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'plantsolve.db').as_posix()}"

    @property
    def resolved_artifact_dir(self) -> Path:
        return self.artifact_dir if self.artifact_dir is not None else self.data_dir / "artifacts"

    @property
    def resolved_blob_store(self) -> str:
        if self.blob_store is not None:
            return self.blob_store
        return "postgres" if self.resolved_database_url.startswith("postgresql") else "local"
