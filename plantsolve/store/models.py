"""SQLAlchemy 2 models of the ``jobs``, ``artifacts`` and ``blobs`` tables, and the dashboard's sessions and failed logins.

The Alembic migrations in ``workers/persistence/migrations`` create exactly these tables;
``tests/service/test_migrations.py`` checks that the two agree.
"""

from __future__ import annotations

import uuid
from datetime import datetime, timezone
from typing import Any

from sqlalchemy import JSON, BigInteger, DateTime, Float, ForeignKey, Index, Integer, LargeBinary, String, Text, Uuid
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from plantsolve.schemas.jobs import JobStatus


def utcnow() -> datetime:
    return datetime.now(timezone.utc)


class Base(DeclarativeBase):
    pass


class Job(Base):
    __tablename__ = "jobs"

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    kind: Mapped[str] = mapped_column(String(64))
    status: Mapped[str] = mapped_column(String(16), default=JobStatus.QUEUED.value)
    attempt: Mapped[int] = mapped_column(Integer, default=0)
    max_attempts: Mapped[int] = mapped_column(Integer, default=3)
    lease_until: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    heartbeat_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    worker: Mapped[str | None] = mapped_column(String(255))
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    progress_message: Mapped[str] = mapped_column(Text, default="")
    # input_kind: "json" (request inline in `input`), "json_file" (request stored as the
    # file `input_file`), "upload" (raw uploaded file `input_file`, parsed by the worker).
    input_kind: Mapped[str] = mapped_column(String(16), default="json")
    input: Mapped[Any | None] = mapped_column(JSON)
    input_file: Mapped[str | None] = mapped_column(Text)
    input_filename: Mapped[str | None] = mapped_column(Text)
    input_options: Mapped[Any | None] = mapped_column(JSON)
    result: Mapped[Any | None] = mapped_column(JSON)
    report: Mapped[Any | None] = mapped_column(JSON)
    # "<owner>:<key>" when the job has an owner: the same key of two tenants names two jobs
    idempotency_key: Mapped[str | None] = mapped_column(String(320), unique=True)
    owner: Mapped[str] = mapped_column(String(64), default="", server_default="")  # "" without API keys
    attempts: Mapped[Any | None] = mapped_column(JSON)  # [{attempt, worker, started_at, finished_at, outcome, error}]
    body_hash: Mapped[str] = mapped_column(String(64))
    solver_version: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    enqueued_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    started_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    # when the attempt now running (or the last one) was claimed: its history entry's start, whoever ends it (the
    # runner, a cancel, the lease policy, a hand-back)
    attempt_started_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    run_seconds: Mapped[float | None] = mapped_column(Float)
    # the completion webhook: state None (no callback) | "pending" | "delivered" | "failed"; while pending,
    # callback_next_at is when the next delivery attempt is due (also the lease of a delivery under way)
    callback_url: Mapped[str | None] = mapped_column(Text)
    callback_state: Mapped[str | None] = mapped_column(String(16))
    callback_attempts: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    callback_next_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    callback_error: Mapped[str | None] = mapped_column(Text)

    __table_args__ = (
        Index("ix_jobs_status_lease", "status", "lease_until"),
        Index("ix_jobs_created", "created_at", "id"),
        Index("ix_jobs_status_created", "status", "created_at", "id"),
        Index("ix_jobs_kind_status_created", "kind", "status", "created_at"),
        Index("ix_jobs_owner_created", "owner", "created_at", "id"),
        Index("ix_jobs_callback_due", "callback_state", "callback_next_at"),
    )


class Artifact(Base):
    __tablename__ = "artifacts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[uuid.UUID] = mapped_column(Uuid, ForeignKey("jobs.id", ondelete="CASCADE"))
    attempt: Mapped[int] = mapped_column(Integer)
    name: Mapped[str] = mapped_column(String(255))
    media_type: Mapped[str] = mapped_column(String(255))
    size: Mapped[int] = mapped_column(Integer)
    sha256: Mapped[str] = mapped_column(String(64))
    path: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)

    __table_args__ = (Index("ux_artifacts_job_name", "job_id", "name", unique=True),)


class DashboardSession(Base):
    """A browser's login to the dashboard: the cookie holds a random token, this row its SHA-256 (a copy of the
    table opens no session) and the SHA-256 of the API key it was opened with (removing the key ends it)."""

    __tablename__ = "dashboard_sessions"

    token_hash: Mapped[str] = mapped_column(String(64), primary_key=True)
    key_hash: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    expires_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))

    __table_args__ = (Index("ix_dashboard_sessions_expires", "expires_at"),)


class LoginFailure(Base):
    """A refused dashboard login, by client address: the rate limit counts them in a sliding window, in the
    database so that every API process counts the same failures."""

    __tablename__ = "login_failures"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    address: Mapped[str] = mapped_column(String(64))
    at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)

    __table_args__ = (Index("ix_login_failures_address_at", "address", "at"),)
class Blob(Base):
    """The bytes of a blob when ``BLOB_STORE=postgres`` (:mod:`plantsolve.store.blobs_database`): one row per
    key. On PostgreSQL the column is stored uncompressed out of line (``STORAGE EXTERNAL``, set by the
    migration), so a download reads it in slices without the server decompressing the whole value."""

    __tablename__ = "blobs"

    key: Mapped[str] = mapped_column(String(512), primary_key=True)
    size: Mapped[int] = mapped_column(BigInteger)
    sha256: Mapped[str] = mapped_column(String(64))
    data: Mapped[bytes] = mapped_column(LargeBinary)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
