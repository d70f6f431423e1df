"""Where the store keeps its data, read from the environment (or a ``.env`` file).

Settings are layered by room, each layer adding what its room needs: :class:`StoreSettings`
(here) → :class:`plantsolve.jobs.settings.JobSettings` (queue and runner) →
:class:`plantsolve.app.settings.AppSettings` (HTTP). All read the same environment, so one
``.env`` configures every process. With nothing set the service runs on the embedded default:
a SQLite file under ``./var``.
"""

from __future__ import annotations

from pathlib import Path

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
        default=None, description="Where artifact and upload files live. Unset: <DATA_DIR>/artifacts."
    )

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'plantsolve.db').as_posix()}"

    @property
    def resolved_artifact_dir(self) -> Path:
        return self.artifact_dir if self.artifact_dir is not None else self.data_dir / "artifacts"
