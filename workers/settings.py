"""Service settings, read from the environment (or a ``.env`` file).

One :class:`Settings` object describes the whole service; :func:`get_settings` caches it,
as FastAPI's settings guide recommends, so tests can clear the cache after changing the
environment. With no variables set the service runs on the embedded default: a SQLite
file under ``./var`` and an in-process job pool.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict
from typing import Annotated


class Settings(BaseSettings):
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
    broker_url: str | None = Field(
        default=None,
        description="Celery broker (redis://host:6379/0). Unset: jobs run in-process (embedded pool).",
    )
    artifact_dir: Path | None = Field(
        default=None, description="Where artifact and upload files live. Unset: <DATA_DIR>/artifacts."
    )
    api_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated API keys. When set, every /v1 call needs 'Authorization: Bearer <key>'.",
    )
    max_body_bytes: int = Field(default=200 * 1024 * 1024, description="Largest accepted request body (413 above).")
    inline_input_bytes: int = Field(
        default=1024 * 1024,
        description="JSON inputs larger than this are stored as a file and referenced from the job row.",
    )
    embedded_workers: int = Field(default=2, ge=1, description="Threads of the in-process job pool.")
    lease_seconds: float = Field(default=60.0, gt=0, description="A running job's lease; renewed by heartbeats.")
    heartbeat_seconds: float = Field(default=10.0, gt=0, description="Heartbeat period of a running job.")
    sweep_seconds: float = Field(default=15.0, gt=0, description="Period of the lapsed-lease sweeper.")
    max_attempts: int = Field(default=3, ge=1, description="Attempts before a crashing or lost job is failed.")
    progress_write_seconds: float = Field(
        default=0.5, ge=0, description="Minimum interval between progress writes (and cancellation checks)."
    )
    auto_migrate: bool = Field(default=True, description="Upgrade the database schema when the API starts.")
    plugins: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated modules imported at start-up that register extra solver kinds "
        "(tests and benchmarks use this).",
    )

    @field_validator("api_keys", "plugins", mode="before")
    @classmethod
    def _split_commas(cls, value: object) -> object:
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'plantsolve.db').as_posix()}"

    @property
    def resolved_artifact_dir(self) -> Path:
        return self.artifact_dir if self.artifact_dir is not None else self.data_dir / "artifacts"

    @property
    def embedded(self) -> bool:
        """True when jobs run in-process (no broker configured)."""
        return not self.broker_url


@lru_cache
def get_settings() -> Settings:
    return Settings()
