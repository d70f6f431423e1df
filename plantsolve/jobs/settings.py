"""Settings of the job domain and its transport: intake, broker, pool size, leases, attempts, plugins.

See :mod:`plantsolve.store.settings` for how the settings are layered. FastAPI's settings
guide is followed: one object per process, cached by :func:`get_job_settings`, so tests
can clear the cache after changing the environment.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated, Literal

from pydantic import Field, ValidationInfo, field_validator
from pydantic_settings import NoDecode

from plantsolve.store.settings import StoreSettings


def split_commas(value: object) -> object:
    if isinstance(value, str):
        return [part.strip() for part in value.split(",") if part.strip()]
    return value


class JobSettings(StoreSettings):
    broker_url: str | None = Field(
        default=None,
        description="Celery broker (redis://host:6379/0). Unset: jobs run in-process (embedded pool).",
    )
    inline_input_bytes: int = Field(
        default=1024 * 1024,
        description="JSON inputs larger than this are stored as a file and referenced from the job row.",
    )
    log_format: Literal["json", "text"] = Field(
        default="json", description="The plantsolve log lines on stderr: one JSON object per line, or plain text.")
    log_level: Literal["critical", "error", "warning", "info", "debug"] = Field(
        default="info",
        description="Least severe plantsolve log line written, in the API and in every job process ('warning' drops "
        "the per-job lines; the command line's --log-level sets it).")
    embedded_workers: int = Field(default=2, ge=1, description="Job processes (or threads) of the embedded pool.")
    embedded_mode: Literal["process", "thread"] = Field(
        default="process",
        description="Embedded default (no broker): 'process' runs jobs in worker processes the service starts and "
        "supervises (the API process never computes; a hard time limit kills the process); 'thread' runs them in "
        "threads of the API process (tests, debugging).")
    job_niceness: int = Field(
        default=10, ge=0, le=19,
        description="Scheduling niceness of the embedded pool's job processes: they share the machine with the API "
        "process, which answers first (0 = same priority as the API).",
    )
    lease_seconds: float = Field(default=60.0, gt=0, description="A running job's lease; renewed by heartbeats.")
    heartbeat_seconds: float = Field(default=10.0, gt=0, description="Heartbeat period of a running job.")
    sweep_seconds: float = Field(default=10.0, gt=0, description="Period of the sweeper (lapsed leases, lost messages).")
    requeue_queued_after: float = Field(
        default=20.0, gt=0,
        description="A queued job whose message is older than this and that the broker no longer holds (its queue "
        "is shorter than the queued jobs) is enqueued again; jobs whose enqueue failed are enqueued at the next sweep.",
    )
    worker_beat_seconds: float = Field(
        default=5.0, gt=0,
        description="Scaled mode: how often each Celery worker tells Redis it is alive (and once when it is ready).")
    worker_alive_seconds: float = Field(
        default=15.0, gt=0,
        description="Scaled mode: a Celery worker last heard from longer ago than this is taken for gone; with none "
        "heard from within it, /readyz is 503 naming 'workers'. Keep it a few beats long (one late beat is no "
        "outage): above WORKER_BEAT_SECONDS.")
    result_write_seconds: float = Field(
        default=60.0, ge=0,
        description="How long the final write of a computed result is retried (with backoff) while the database is "
        "unreachable; after that the result waits on disk and the next attempt stores it without solving again.",
    )
    time_limits: dict[str, float] = Field(
        default_factory=dict,
        description='Hard time limit per kind in seconds, overriding the kind\'s own (JSON: {"tube": 1200}).',
    )
    soft_time_limits: dict[str, float] = Field(
        default_factory=dict, description="Soft time limit per kind in seconds (the solver is asked to stop)."
    )
    max_attempts: int = Field(default=3, ge=1, description="Attempts before a crashing or lost job is failed.")
    progress_write_seconds: float = Field(
        default=0.5, ge=0, description="Minimum interval between progress writes (and cancellation checks)."
    )
    plugins: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated modules, each exporting SPECS (a sequence of SolverSpec): extra "
        "solver kinds for tests and benchmarks, added to the built-in kind map.",
    )

    @field_validator("plugins", mode="before")
    @classmethod
    def _split_plugins(cls, value: object) -> object:
        return split_commas(value)

    @field_validator("worker_alive_seconds")
    @classmethod
    def _alive_spans_a_beat(cls, value: float, info: ValidationInfo) -> float:
        beat = info.data.get("worker_beat_seconds")
        if beat is not None and value <= beat:
            raise ValueError(f"must be longer than WORKER_BEAT_SECONDS ({beat}): a live worker would flicker out "
                             "between its beats")
        return value

    @property
    def embedded(self) -> bool:
        """True when jobs run in-process (no broker configured)."""
        return not self.broker_url


@lru_cache
def get_job_settings() -> JobSettings:
    return JobSettings()
