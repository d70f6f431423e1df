"""Models of the job API: job status views, listings, artifacts and problem documents."""

from __future__ import annotations

from datetime import datetime
from enum import StrEnum
from typing import Any, Literal
from uuid import UUID

from pydantic import BaseModel, Field

from plantsolve.schemas.common import Report

class JobStatus(StrEnum):
    """Where a job is in its life; the transitions between them are in :mod:`plantsolve.jobs.lifecycle`."""

    QUEUED = "queued"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"


class JobProgress(BaseModel):
    fraction: float = Field(ge=0, le=1, description="Share of the work done, 0 to 1.")
    message: str = Field(description="What the solver is doing now.")


class JobTimings(BaseModel):
    created_at: datetime
    started_at: datetime | None = Field(description="First claim by a worker.")
    finished_at: datetime | None
    queued_seconds: float | None = Field(description="From submission to the first start.")
    run_seconds: float | None = Field(description="Duration of the attempt that finished the job.")


class ArtifactInfo(BaseModel):
    name: str
    media_type: str
    size: int = Field(description="Bytes.")
    sha256: str
    url: str


class AttemptInfo(BaseModel):
    """One attempt at running the job, as the runner or the sweeper recorded it."""

    attempt: int
    worker: str | None = None
    started_at: datetime | None = Field(default=None, description="When the attempt was claimed, whoever ended it "
                                        "(null only for an attempt that ran before the service recorded starts).")
    finished_at: datetime | None = None
    outcome: Literal["succeeded", "failed", "requeued", "time_limit", "cancelled", "lost", "result_pending",
                     "handed_back"] = Field(
        description="lost: the worker stopped heartbeating; handed_back: the service stopped while it ran (the "
        "job was re-queued, the attempt not counted); result_pending: computed, but the database did not take "
        "the result (it is stored by the next attempt without solving again)."
    )
    error: str | None = None


class CallbackInfo(BaseModel):
    """The completion webhook asked for at submission (``?callback_url=``)."""

    url: str
    state: Literal["pending", "delivered", "failed"] = Field(
        description="pending: not yet delivered (the job is running, or a retry is due); failed: every attempt failed.")
    attempts: int = Field(description="Deliveries tried so far.")
    error: str | None = Field(default=None, description="Why the last delivery failed.")


class JobView(BaseModel):
    """A job's status. ``report`` is present once the job has finished (and after a failed
    attempt that was re-queued)."""

    id: UUID
    kind: str
    status: JobStatus
    attempt: int = Field(description="Attempts started so far.")
    max_attempts: int
    progress: JobProgress
    timings: JobTimings
    solver_version: str
    idempotency_key: str | None = None
    summary: str = Field(description="One line for people: what happened or is happening.")
    report: Report | None = None
    artifacts: list[ArtifactInfo] = Field(default_factory=list)
    attempts: list[AttemptInfo] = Field(default_factory=list, description="Every attempt so far, oldest first.")
    links: dict[str, str] = Field(description="self, result, cancel (URLs relative to the host).")
    callback: CallbackInfo | None = Field(default=None, description="The completion webhook, when one was asked for.")


class UploadedInput(BaseModel):
    """What a file upload submitted: the file's name and size, the multipart ``options``, and where the bytes are."""

    filename: str = Field(description="The uploaded file's name, as sent.")
    options: dict[str, Any] | None = Field(description="The multipart 'options' JSON object (null when none was sent).")
    size: int = Field(description="Bytes of the file.")
    file: str = Field(description="URL of the file itself (GET /v1/jobs/{id}/input/file).")


class JobList(BaseModel):
    items: list[JobView]
    next_cursor: str | None = Field(description="Pass as ?cursor= to get the next page; null on the last page.")


class FieldProblem(BaseModel):
    loc: list[str | int] = Field(description="JSON path of the bad field, e.g. ['components', 3, 'ports'].")
    pointer: str = Field(description="The same path as an RFC 6901 JSON pointer, e.g. '/components/3/ports'.")
    msg: str
    type: str


class Problem(BaseModel):
    """RFC 9457 problem details (media type ``application/problem+json``)."""

    type: str = Field(default="about:blank")
    title: str
    status: int
    detail: str | None = None
    instance: str | None = None
    errors: list[FieldProblem] | None = Field(default=None, description="One entry per bad field (422).")
    extra: dict[str, Any] | None = Field(default=None, description="Machine-readable context, e.g. a job's report.")


class HealthStatus(BaseModel):
    status: Literal["ok", "unavailable"]
    checks: dict[str, str] = Field(default_factory=dict)
