"""Every read and write of the ``jobs`` and ``artifacts`` tables.

Writes made on behalf of a running attempt are *fenced*: they carry the attempt number and
only apply while the row is still ``running`` with that attempt. A worker whose lease lapsed
(and whose job was re-queued and claimed again), or whose job was cancelled, therefore can
never overwrite what a newer attempt or the user did: its update matches no row.
"""

from __future__ import annotations

import asyncio
import functools
import uuid
from concurrent.futures import Future
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from typing import Any, Callable, Iterable

from sqlalchemy import String, Text, and_, bindparam, case, cast, delete, func, insert, or_, select, update
from sqlalchemy.dialects import postgresql
from sqlalchemy.exc import DBAPIError, IntegrityError
from sqlalchemy.orm import Session, sessionmaker

from plantsolve.jobs.lifecycle import ACTIVE, CANCEL, CLAIM, FAIL, FINISHED, QUEUED, REQUEUE, RUNNING, SUCCEED
from plantsolve.store.loop_connections import LoopConnections
from plantsolve.store.models import Artifact, Job, utcnow
from plantsolve.store.writer import JobWriter


def as_utc(value: datetime | None) -> datetime | None:
    """SQLite hands back naive datetimes; every stored time is UTC."""
    if value is None or value.tzinfo is not None:
        return value
    return value.replace(tzinfo=timezone.utc)


@dataclass(frozen=True)
class StoredArtifact:
    name: str
    media_type: str
    size: int
    sha256: str
    path: str


@dataclass(frozen=True)
class JobState:
    """A job's status and progress: what changes while it runs."""

    id: uuid.UUID
    kind: str
    status: str
    attempt: int
    progress: float
    progress_message: str

    @classmethod
    def of(cls, job: Job) -> "JobState":
        return cls(job.id, job.kind, job.status, job.attempt, job.progress, job.progress_message or "")

    @property
    def signature(self) -> tuple:
        return self.status, self.attempt, self.progress, self.progress_message


@dataclass(frozen=True, slots=True, eq=False, repr=False)
class JobRecord:
    """A job as the store holds it: every column, read once and never changed (a write is a new read). Every read
    of the repository returns this type, whatever query made it. A *brief* record (``complete`` False) leaves out
    the input and the result: a status read must not load and decode a result of many megabytes it does not show."""

    id: uuid.UUID
    kind: str
    status: str
    attempt: int
    max_attempts: int
    lease_until: datetime | None
    heartbeat_at: datetime | None
    worker: str | None
    progress: float
    progress_message: str
    input_kind: str
    input: Any
    input_file: str | None
    input_filename: str | None
    input_options: Any
    result: Any
    report: dict | None
    idempotency_key: str | None
    owner: str
    attempts: list | None
    body_hash: str
    solver_version: str
    created_at: datetime
    enqueued_at: datetime | None
    started_at: datetime | None
    attempt_started_at: datetime | None
    finished_at: datetime | None
    run_seconds: float | None
    callback_url: str | None
    callback_state: str | None
    callback_attempts: int
    callback_next_at: datetime | None
    callback_error: str | None
    complete: bool = True

    @classmethod
    def of(cls, row: Any, *, complete: bool = True) -> "JobRecord":
        """From a row of the jobs table (its columns by name). A brief record has no input, input options or
        result at all (reading one is an AttributeError, not a None that would pass for "none given")."""
        values = dict(row._mapping) if hasattr(row, "_mapping") else dict(row)
        for name in LEFT_OUT_OF_BRIEF:
            values.setdefault(name, None)
        values["progress_message"] = values.get("progress_message") or ""
        values["owner"] = values.get("owner") or ""
        values["callback_attempts"] = values.get("callback_attempts") or 0
        record = cls(**values, complete=complete)
        if not complete:
            for name in LEFT_OUT_OF_BRIEF:
                object.__delattr__(record, name)
        return record

    def __repr__(self) -> str:
        return f"JobRecord(id={self.id}, kind={self.kind!r}, status={self.status!r}, attempt={self.attempt})"


LEFT_OUT_OF_BRIEF = ("input", "input_options", "result")


@dataclass(frozen=True)
class LapsedAttempt:
    """A running attempt whose lease lapsed (or whose worker is gone): what the lease policy needs to decide its
    fate."""

    id: uuid.UUID
    kind: str
    attempt: int
    max_attempts: int
    attempts: list
    worker: str | None
    heartbeat_at: datetime | None
    report: dict | None = None  # what the job's report says meanwhile (the reader's warnings an attempt wrote)
    started_at: datetime | None = None  # when the attempt was claimed


class JobRepository:
    """``group_commit``: new jobs are inserted by one writer thread, in one transaction per batch of concurrent
    submissions (:mod:`plantsolve.store.writer`; right for SQLite, which has one writer at a time anyway).
    ``loop_connections`` (PostgreSQL): an event loop may insert new jobs itself (:meth:`create_on_loop`)."""

    def __init__(self, sessions: sessionmaker[Session], writing: Callable[[], AbstractContextManager] = nullcontext,
                 *, group_commit: bool = False, loop_connections: LoopConnections | None = None):
        self.sessions = sessions
        self.writing = writing  # see Database.writing
        self.writer = JobWriter(sessions.kw["bind"], JOBS, writing, self.get_by_idempotency_key,
                                 made=JobRecord.of) if group_commit \
            else None
        engine = sessions.kw["bind"]
        self._insert = DriverInsert(engine, JOBS) if engine.dialect.driver == "psycopg" else None
        self._loop_connections = loop_connections

    def close(self) -> None:
        """Write the submissions still queued for the writer thread, and end it."""
        if self.writer is not None:
            self.writer.close()

    @property
    def _engine(self):
        return self.sessions.kw["bind"]

    def _core(self):
        """A connection in a transaction, committed on leaving (rolled back on an error), for Core statements on the
        hot paths (submit, claim, progress, finish): an ORM session's bookkeeping costs more than such a write."""
        return self.sessions.kw["bind"].begin()

    # ---- submission and reads -------------------------------------------------------------

    def create(self, values: dict[str, Any]) -> tuple[JobRecord, bool]:
        """Insert a job given as its columns (the columns' defaults fill what is left out); with an idempotency key
        already taken, return the existing job instead. Returns ``(job, created)``; the caller compares body hashes
        of an existing job. One Core INSERT and no ORM instance: on the submit path the ORM's unit of work and
        instance bookkeeping cost more than the write itself."""
        if self.writer is not None:
            return self.create_later(values).result()
        key = values.get("idempotency_key")
        # a taken key is found by the insert itself (the key's unique index), as by the group commit: no read before
        # it, which a new key (the common case) would pay for in a round trip
        record = new_job_row(values)
        given = _given(record)
        try:
            if self._insert is not None:
                self._insert(given)
            else:
                with self.writing(), \
                        self._engine.connect().execution_options(isolation_level="AUTOCOMMIT") as connection:
                    connection.execute(INSERT_JOB, given)
        except IntegrityError:
            existing = self.get_by_idempotency_key(key) if key is not None else None
            if existing is None:
                raise
            return existing, False
        return JobRecord.of(record), True

    @property
    def creates_on_loop(self) -> bool:
        """Whether :meth:`create_on_loop` may be awaited (PostgreSQL, with loop connections)."""
        return self._loop_connections is not None

    async def create_on_loop(self, values: dict[str, Any]) -> tuple[JobRecord, bool]:
        """:meth:`create`, awaited on the event loop (the INSERT on one of its connections: no thread); the row
        committed when it returns. The read of the job that holds a taken idempotency key (a repeated request: rare)
        goes to a thread."""
        key = values.get("idempotency_key")
        record = new_job_row(values)
        given = _given(record)
        try:
            await self._loop_connections.execute(loop_insert(tuple(given)), *given.values())
        except IntegrityError:
            existing = await asyncio.to_thread(self.get_by_idempotency_key, key) if key is not None else None
            if existing is None:
                raise
            return existing, False
        return JobRecord.of(record), True

    def create_later(self, values: dict[str, Any]) -> Future | None:
        """:meth:`create` of a job given as its columns through the writer thread: a future of ``(job, created)``
        answered once the row is committed (None without group commit). A taken idempotency key is found by the
        insert itself (the key's unique index), not by a read before it."""
        if self.writer is None:
            return None
        return self.writer.create(new_job_row(values))

    def get(self, job_id: uuid.UUID, *, brief: bool = False) -> JobRecord | None:
        """The job; ``brief`` leaves out the input and the result (see :class:`JobRecord`)."""
        with self.sessions.kw["bind"].connect() as connection:
            row = connection.execute(BRIEF_BY_ID if brief else FULL_BY_ID, {"job_id": job_id}).first()
        return JobRecord.of(row, complete=not brief) if row is not None else None

    @property
    def reads_on_loop(self) -> bool:
        """Whether :meth:`get_brief_on_loop` may be awaited (PostgreSQL, with loop connections)."""
        return self._loop_connections is not None

    async def get_brief_on_loop(self, job_id: uuid.UUID) -> tuple[JobRecord | None, list[StoredArtifact]]:
        """:meth:`get` of a brief record awaited on the event loop, with the job's artifacts when it succeeded (what
        its view shows), without a thread or SQLAlchemy's execution context: the values the Core read returns."""
        rows = await self._loop_connections.fetch(BRIEF_BY_ID_SQL, job_id)
        if not rows:
            return None, []
        job = JobRecord.of(dict(zip(BRIEF_KEYS, rows[0])), complete=False)
        if job.status != SUCCEED.target:
            return job, []
        return job, [StoredArtifact(*row) for row in await self._loop_connections.fetch(ARTIFACTS_OF_JOB_SQL, job_id)]

    def state(self, job_id: uuid.UUID) -> JobState | None:
        """The columns an event stream watches, read by primary key (no input, result or report)."""
        with self.sessions() as session:
            row = session.execute(select(*STATE).where(Job.id == job_id)).first()
        return JobState(*row) if row is not None else None

    def states(self, *, since: datetime, ids: Iterable[uuid.UUID] = (), owner: str | None = None,
               kind: str | None = None) -> list[JobState]:
        """What a stream of every job watches: the queued and running jobs, those created at or after
        ``since``, and the jobs ``ids`` (those seen active before: to learn how they ended). Each part is
        an indexed read, so a poll costs in proportion to the jobs in flight, not to the table."""
        ids = list(ids)
        queries = [select(*STATE).where(Job.status.in_(ACTIVE)),
                   select(*STATE).where(Job.created_at >= since)]
        queries += [select(*STATE).where(Job.id.in_(ids[i:i + 500])) for i in range(0, len(ids), 500)]
        found: dict[uuid.UUID, JobState] = {}
        with self.sessions() as session:
            for query in queries:
                if owner is not None:
                    query = query.where(Job.owner == owner)
                if kind:
                    query = query.where(Job.kind == kind)
                for row in session.execute(query):
                    found[row[0]] = JobState(*row)
        return list(found.values())

    def get_by_idempotency_key(self, key: str) -> JobRecord | None:
        with self.sessions.kw["bind"].connect() as connection:
            row = connection.execute(select(JOBS).where(JOBS.c.idempotency_key == key)).first()
        return JobRecord.of(row) if row is not None else None

    def list(
        self,
        *,
        kind: str | None = None,
        status: str | None = None,
        after: tuple[datetime, uuid.UUID] | None = None,
        limit: int = 50,
        owner: str | None = None,
        text: str | None = None,
        brief: bool = False,
    ) -> list[JobRecord]:
        """Newest first; ``after`` is the (created_at, id) of the last job of the previous page; ``owner``
        None lists every tenant's jobs; ``text`` keeps jobs whose id, kind, progress message or report
        contains it (case-insensitive); ``brief`` leaves out inputs and results."""
        query = select(*(BRIEF_COLUMNS if brief else JOBS.columns)).order_by(Job.created_at.desc(), Job.id.desc()) \
            .limit(limit)
        if text:
            query = query.where(_contains_text(text))
        if owner is not None:
            query = query.where(Job.owner == owner)
        if kind:
            query = query.where(Job.kind == kind)
        if status:
            query = query.where(Job.status == status)
        if after is not None:
            created, last_id = after
            query = query.where(
                or_(Job.created_at < created, and_(Job.created_at == created, Job.id < last_id))
            )
        with self.sessions.kw["bind"].connect() as connection:
            return [JobRecord.of(row, complete=not brief) for row in connection.execute(query)]

    def count_by_status(self, owner: str | None = None) -> dict[str, int]:
        query = select(Job.status, func.count()).group_by(Job.status)
        if owner is not None:
            query = query.where(Job.owner == owner)
        with self.sessions() as session:
            rows = session.execute(query)
            return {status: count for status, count in rows}

    # the metrics' queries: ``owner`` None counts every tenant's jobs, a name only that tenant's

    def count_by_kind_status(self, owner: str | None = None) -> list[tuple[str, str, int]]:
        query = select(Job.kind, Job.status, func.count()).group_by(Job.kind, Job.status)
        if owner is not None:
            query = query.where(Job.owner == owner)
        with self.sessions() as session:
            return [(kind, status, int(n)) for kind, status, n in session.execute(query)]

    def oldest_queued(self, owner: str | None = None) -> list[tuple[str, datetime]]:
        """Per kind, when its longest-waiting queued job was submitted."""
        query = select(Job.kind, func.min(Job.created_at)).where(Job.status == QUEUED).group_by(Job.kind)
        if owner is not None:
            query = query.where(Job.owner == owner)
        with self.sessions() as session:
            return [(kind, as_utc(created)) for kind, created in session.execute(query)]

    def run_time_histogram(self, buckets: Iterable[float],
                           owner: str | None = None) -> list[tuple[str, str, int, float, list[int]]]:
        """Per kind and final status of the finished jobs: count, sum of run seconds, and the cumulative count
        at or below each bucket bound, computed by the database in one pass."""
        buckets = list(buckets)
        seconds = Job.run_seconds
        columns = [func.sum(case((seconds <= bound, 1), else_=0)) for bound in buckets]
        query = (select(Job.kind, Job.status, func.count(), func.sum(seconds), *columns)
                 .where(Job.status.in_(FINISHED), seconds.is_not(None)).group_by(Job.kind, Job.status))
        if owner is not None:
            query = query.where(Job.owner == owner)
        with self.sessions() as session:
            return [(row[0], row[1], int(row[2]), float(row[3] or 0.0), [int(v or 0) for v in row[4:]])
                    for row in session.execute(query)]

    def artifacts(self, job_id: uuid.UUID) -> list[Artifact]:
        with self.sessions() as session:
            return list(session.scalars(select(Artifact).where(Artifact.job_id == job_id).order_by(Artifact.name)))

    def artifact(self, job_id: uuid.UUID, name: str) -> Artifact | None:
        with self.sessions() as session:
            return session.scalars(
                select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name)
            ).first()

    def mark_enqueued(self, job_id: uuid.UUID) -> None:
        self._execute(update(JOBS).where(JOBS.c.id == job_id).values(enqueued_at=utcnow()))

    # ---- the attempt's life: claim, heartbeat, progress, finish ----------------------------

    def claim(self, job_id: uuid.UUID, *, lease_seconds: float, worker: str) -> int | None:
        """queued (or running with a lapsed lease) -> running, attempt+1. Returns the attempt
        number now owned by the caller, or None if the job is not claimable."""
        now = utcnow()
        statement = (
            update(JOBS)
            .where(
                JOBS.c.id == job_id,
                JOBS.c.attempt < JOBS.c.max_attempts,
                or_(JOBS.c.status == QUEUED, and_(JOBS.c.status == RUNNING, JOBS.c.lease_until < now)),
            )
            .values(
                status=CLAIM.target,
                attempt=JOBS.c.attempt + 1,
                lease_until=now + timedelta(seconds=lease_seconds),
                heartbeat_at=now,
                started_at=func.coalesce(JOBS.c.started_at, now),
                attempt_started_at=now,
                worker=worker,
                progress=0.0,
                progress_message="started",
            )
            .returning(JOBS.c.attempt)
        )
        with self.writing(), self._core() as connection:
            return connection.execute(statement).scalar_one_or_none()

    def heartbeat(self, job_id: uuid.UUID, attempt: int, *, lease_seconds: float) -> bool:
        """Extend the lease; False when the attempt no longer owns the job (stale or cancelled)."""
        now = utcnow()
        return self._fenced(job_id, attempt, lease_until=now + timedelta(seconds=lease_seconds), heartbeat_at=now)

    def set_progress(self, job_id: uuid.UUID, attempt: int, fraction: float, message: str) -> bool:
        return self._fenced(job_id, attempt, progress=fraction, progress_message=message[:2000])

    def note_report(self, job_id: uuid.UUID, attempt: int, report: Any) -> bool:
        """The running attempt's report until it ends (fenced): what the attempt has to say already."""
        return self._fenced(job_id, attempt, report=report)

    def finish_success(
        self,
        job_id: uuid.UUID,
        attempt: int,
        *,
        result: Any,
        report: Any,
        artifacts: Iterable[StoredArtifact],
        run_seconds: float,
        attempts: list | None = None,
    ) -> bool:
        """Store result and artifacts in one transaction, fenced on the attempt."""
        now = utcnow()
        extra = {} if attempts is None else {"attempts": attempts}
        with self.writing(), self._core() as connection:
            updated = connection.execute(
                self._fence(job_id, attempt).values(
                    status=SUCCEED.target,
                    result=result,
                    report=report,
                    progress=1.0,
                    progress_message="done",
                    finished_at=now,
                    lease_until=None,
                    run_seconds=run_seconds,
                    **extra,
                )
            ).rowcount
            if updated != 1:
                connection.rollback()
                return False
            connection.execute(delete(ARTIFACTS).where(ARTIFACTS.c.job_id == job_id))
            rows = [{"job_id": job_id, "attempt": attempt, "name": a.name, "media_type": a.media_type, "size": a.size,
                     "sha256": a.sha256, "path": a.path} for a in artifacts]
            if rows:
                connection.execute(insert(ARTIFACTS), rows)
            return True

    def finish_failure(self, job_id: uuid.UUID, attempt: int, *, report: Any, run_seconds: float | None,
                       attempts: list | None = None, lapsed_before: datetime | None = None) -> bool:
        """Fail the attempt (fenced); with ``lapsed_before``, only while its lease lapsed before that time."""
        extra = {} if attempts is None else {"attempts": attempts}
        return self._fenced(
            job_id,
            attempt,
            lapsed_before,
            status=FAIL.target,
            report=report,
            finished_at=utcnow(),
            lease_until=None,
            run_seconds=run_seconds,
            **extra,
        )

    def requeue(self, job_id: uuid.UUID, attempt: int, *, report: Any, attempts: list | None = None,
                grant_attempt: bool = False, lapsed_before: datetime | None = None) -> bool:
        """Give a crashed attempt's job back to the queue (the caller enqueues it again). ``grant_attempt``
        adds one attempt to the cap: for a result that waits on disk, whose storing must not be refused
        because the attempt that computed it was the last."""
        extra: dict[str, Any] = {} if attempts is None else {"attempts": attempts}
        if grant_attempt:
            extra["max_attempts"] = Job.max_attempts + 1
        return self._fenced(job_id, attempt, lapsed_before, status=REQUEUE.target, report=report, lease_until=None,
                            worker=None, **extra)

    def extend_leases(self, lease_seconds: float) -> int:
        """Give every running attempt a full lease from now (after the database was away, so that no
        lease counts as lapsed for the time nobody could heartbeat). Returns how many were extended."""
        until = utcnow() + timedelta(seconds=lease_seconds)
        return self._execute(update(JOBS).where(JOBS.c.status == RUNNING, JOBS.c.lease_until < until)
                             .values(lease_until=until))

    # ---- user actions and housekeeping -----------------------------------------------------

    def cancel(self, job_id: uuid.UUID, *, report: Any, attempts: list | None = None,
               seen: tuple[str, int] | None = None) -> str | None:
        """Cancel a queued or running job, with the attempt history ``attempts`` when given. ``seen``: only while the
        job is still at that (status, attempt). Returns the status the job has afterwards, or None when it does not
        exist. A running attempt notices at its next fenced write."""
        statement = update(Job).where(Job.id == job_id, Job.status.in_(CANCEL.sources))
        if seen is not None:
            statement = statement.where(Job.status == seen[0], Job.attempt == seen[1])
        extra = {} if attempts is None else {"attempts": attempts}
        with self.writing(), self.sessions() as session:
            updated = session.execute(
                statement.values(status=CANCEL.target, finished_at=utcnow(), lease_until=None, report=report, **extra)
            ).rowcount
            session.commit()
            if updated == 1:
                return CANCEL.target
            job = session.get(Job, job_id)
            return job.status if job is not None else None

    def lapsed(self, now: datetime) -> list["LapsedAttempt"]:
        """Running attempts whose lease lapsed before ``now`` (their worker stopped heartbeating). The lease policy
        (:mod:`plantsolve.jobs.leases`) decides what becomes of each."""
        return self._running(JOBS.c.lease_until < now)

    def running_attempts(self) -> list["LapsedAttempt"]:
        """Every running attempt, its lease lapsed or not: the lease policy asks the transport whether each one's
        worker still runs (:func:`plantsolve.jobs.leases.sweep_once`)."""
        return self._running()

    def _running(self, *conditions) -> list["LapsedAttempt"]:
        with self.sessions.kw["bind"].connect() as connection:
            rows = connection.execute(
                select(JOBS.c.id, JOBS.c.kind, JOBS.c.attempt, JOBS.c.max_attempts, JOBS.c.attempts, JOBS.c.worker,
                       JOBS.c.heartbeat_at, JOBS.c.report, JOBS.c.attempt_started_at)
                .where(JOBS.c.status == RUNNING, *conditions)).all()
        return [LapsedAttempt(job_id, kind, attempt, max_attempts, list(history or []), worker, as_utc(beat), report,
                              as_utc(started))
                for job_id, kind, attempt, max_attempts, history, worker, beat, report, started in rows]

    def unsent(self, *, sent_before: datetime, limit: int = 1000) -> list[tuple[uuid.UUID, bool]]:
        """Queued jobs whose message never reached the broker, or reached it before ``sent_before``: ``(id, reached
        the broker)``, never sent first, then the oldest."""
        with self.sessions.kw["bind"].connect() as connection:
            rows = connection.execute(
                select(JOBS.c.id, JOBS.c.enqueued_at).where(
                    JOBS.c.status == QUEUED, or_(JOBS.c.enqueued_at.is_(None), JOBS.c.enqueued_at < sent_before)
                ).order_by(JOBS.c.enqueued_at.is_not(None), JOBS.c.created_at).limit(limit)).all()
        return [(job_id, sent is not None) for job_id, sent in rows]

    def mark_queued(self, message: str, *, only: str | None = None) -> int:
        """Set the progress message of the queued jobs (those whose message is ``only``, when given) to ``message``:
        what a queued job waits for. Returns how many changed."""
        statement = update(JOBS).where(JOBS.c.status == QUEUED, JOBS.c.progress_message != message)
        if only is not None:
            statement = statement.where(JOBS.c.progress_message == only)
        return self._execute(statement.values(progress_message=message))

    def count_queued(self) -> int:
        with self.sessions() as session:
            return int(session.scalar(select(func.count()).select_from(Job).where(Job.status == QUEUED)))

    def clear_enqueued(self, job_id: uuid.UUID) -> None:
        """The message never reached the broker: the next sweep sends it."""
        self._execute(update(JOBS).where(JOBS.c.id == job_id).values(enqueued_at=None))

    def queued_jobs(self, limit: int | None = None) -> list[tuple[uuid.UUID, str]]:
        """``(id, kind)`` of the queued jobs that a worker can claim, oldest first (the kind spares the caller a
        read of each row to find its time limit)."""
        query = (select(JOBS.c.id, JOBS.c.kind).where(JOBS.c.status == QUEUED, JOBS.c.attempt < JOBS.c.max_attempts)
                 .order_by(JOBS.c.created_at, JOBS.c.id).limit(limit))
        # a Core read on a plain connection: the embedded pool runs it as jobs finish while a backlog waits, in the
        # API process, where an ORM session's bookkeeping would cost more than the read
        with self.sessions.kw["bind"].connect() as connection:
            return [(job_id, kind) for job_id, kind in connection.execute(query)]

    # ---- the completion webhook ---------------------------------------------------------------

    def due_callbacks(self, limit: int = 20) -> list[uuid.UUID]:
        """Finished jobs whose callback is pending and due, the longest waiting first."""
        now = utcnow()
        query = (select(Job.id).where(Job.callback_state == "pending", Job.callback_next_at <= now,
                                      Job.status.in_(FINISHED))
                 .order_by(Job.callback_next_at).limit(limit))
        with self.sessions() as session:
            return list(session.scalars(query))

    def claim_callback(self, job_id: uuid.UUID, *, lease_seconds: float) -> int | None:
        """Take one delivery attempt (a conditional update only one process wins); until it is recorded,
        the lease keeps others off. Returns the attempt number, or None when another process has it."""
        now = utcnow()
        statement = (update(JOBS)
                     .where(JOBS.c.id == job_id, JOBS.c.callback_state == "pending", JOBS.c.callback_next_at <= now)
                     .values(callback_attempts=JOBS.c.callback_attempts + 1,
                             callback_next_at=now + timedelta(seconds=lease_seconds))
                     .returning(JOBS.c.callback_attempts))
        with self.writing(), self._core() as connection:
            return connection.execute(statement).scalar_one_or_none()

    def record_callback(self, job_id: uuid.UUID, attempt: int, *, state: str, error: str | None = None,
                        next_at: datetime | None = None) -> bool:
        """The outcome of delivery ``attempt``: "delivered", "failed" (gave up) or "pending" again at ``next_at``."""
        return self._execute(
            update(JOBS).where(JOBS.c.id == job_id, JOBS.c.callback_attempts == attempt, JOBS.c.callback_state == "pending")
            .values(callback_state=state, callback_error=error[:2000] if error else None, callback_next_at=next_at)) == 1

    # ---- helpers ----------------------------------------------------------------------------

    @staticmethod
    def _fence(job_id: uuid.UUID, attempt: int):
        # every transition out of running starts here: the attempt that holds the job. Core statements on the
        # table: an ORM-enabled UPDATE costs several times its own write in statement building and session sync
        return update(JOBS).where(JOBS.c.id == job_id, JOBS.c.attempt == attempt, JOBS.c.status == RUNNING)

    def _fenced(self, job_id: uuid.UUID, attempt: int, lapsed_before: datetime | None = None, **values: Any) -> bool:
        statement = self._fence(job_id, attempt)
        if lapsed_before is not None:  # a sweeper's write: only while no heartbeat renewed the lease meanwhile
            statement = statement.where(JOBS.c.lease_until < lapsed_before)
        return self._execute(statement.values(**values)) == 1

    def _execute(self, statement) -> int:
        with self.writing(), self._core() as connection:
            return connection.execute(statement).rowcount


JOBS = Job.__table__
ARTIFACTS = Artifact.__table__
STATE = (Job.id, Job.kind, Job.status, Job.attempt, Job.progress, Job.progress_message)


def _contains_text(text: str):
    """Substring match, case-insensitive, with LIKE's wildcards taken literally. The id is compared
    without dashes: SQLite stores a UUID as 32 hex digits, PostgreSQL prints it with dashes."""
    def pattern(value: str) -> str:
        escaped = value.lower().replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_")
        return f"%{escaped}%"

    like, bare = pattern(text), pattern(text.replace("-", ""))
    return or_(
        func.lower(func.replace(cast(Job.id, String), "-", "")).like(bare, escape="\\"),
        func.lower(Job.kind).like(like, escape="\\"),
        func.lower(Job.progress_message).like(like, escape="\\"),
        func.lower(cast(Job.report, Text)).like(like, escape="\\"),
    )


def _default(column) -> Callable[[], Any]:
    default = column.default
    return (lambda: default.arg(None)) if default.is_callable else (lambda: default.arg)


COLUMN_KEYS = tuple(column.key for column in JOBS.columns)
COLUMN_DEFAULTS = tuple((column.key, _default(column)) for column in JOBS.columns if column.default is not None)
INSERT_JOB = JOBS.insert()
# the columns a job's view shows: all but the input and the result
BRIEF_COLUMNS = tuple(column for column in JOBS.columns if column.key not in LEFT_OUT_OF_BRIEF)
BRIEF_BY_ID = select(*BRIEF_COLUMNS).where(JOBS.c.id == bindparam("job_id"))
# the statements of the event loop's connections (PostgreSQL, asyncpg's placeholders): the brief read, a succeeded
# job's artifacts, the INSERT of the given columns
_quote = postgresql.dialect().identifier_preparer.quote
BRIEF_KEYS = tuple(column.key for column in BRIEF_COLUMNS)
BRIEF_BY_ID_SQL = f"SELECT {', '.join(_quote(c.name) for c in BRIEF_COLUMNS)} FROM {JOBS.name} WHERE id = $1"
ARTIFACTS_OF_JOB_SQL = (f"SELECT name, media_type, size, sha256, path FROM {ARTIFACTS.name} WHERE job_id = $1 "
                        "ORDER BY name")


def _given(record: dict[str, Any]) -> dict[str, Any]:
    """The columns a new job's INSERT sets: unset ones stay SQL NULL (a None in a JSON column would be stored as
    JSON null)."""
    return {name: value for name, value in record.items() if value is not None}


@functools.cache
def loop_insert(keys: tuple[str, ...]) -> str:
    """The INSERT of a new job's given columns (``keys``), as :class:`DriverInsert` writes it."""
    return (f"INSERT INTO {JOBS.name} ({', '.join(_quote(JOBS.c[key].name) for key in keys)}) "
            f"VALUES ({', '.join(f'${i}' for i in range(1, len(keys) + 1))})")
FULL_BY_ID = select(JOBS).where(JOBS.c.id == bindparam("job_id"))


class DriverInsert:
    """The INSERT of one row into ``table`` on a pooled PostgreSQL connection, sent through the driver (psycopg) in
    autocommit: one statement is its own transaction, so one round trip (no BEGIN and COMMIT around it), and the
    commit is the server's own (durable when the call returns). The values go through the columns' own bind
    processors and the SQL names the given columns only (the rest keep their defaults), so the row is the one
    SQLAlchemy's compiled insert would write; SQLAlchemy's execution context, compiled-cache lookup and the isolation
    level set and reset per checkout cost more than the write on the submit path. The pool's checkout events run as
    for any connection (the ping after idle; the round-trip bound of the connection class), a driver error comes back
    as SQLAlchemy's exception of its class (an ``IntegrityError`` for a taken unique key), and a connection the
    error broke is invalidated, as SQLAlchemy does."""

    def __init__(self, engine, table):
        self.engine = engine
        self.table = table.name
        quote = engine.dialect.identifier_preparer.quote
        self.names = {column.key: quote(column.name) for column in table.columns}
        self.processors = {column.key: column.type.dialect_impl(engine.dialect).bind_processor(engine.dialect)
                           for column in table.columns}
        self._statements: dict[tuple[str, ...], str] = {}

    def __call__(self, values: dict[str, Any]) -> None:
        """Insert ``values`` (column key to a value that is not None) and commit."""
        statement, params = self._statement(values)
        pooled = None
        try:
            pooled = self.engine.raw_connection()
            driver = pooled.driver_connection
            driver.set_autocommit(True)
            try:
                driver.execute(statement, params)
            finally:
                if not driver.closed:
                    driver.set_autocommit(False)
        except self.engine.dialect.loaded_dbapi.Error as error:
            invalidated = pooled is not None and self.engine.dialect.is_disconnect(error, pooled.dbapi_connection, None)
            if invalidated:
                pooled.invalidate(error)
            raise self._error(error, statement, params, invalidated) from error
        finally:
            if pooled is not None:
                pooled.close()

    def _statement(self, values: dict[str, Any]) -> tuple[str, tuple]:
        keys = tuple(values)
        statement = self._statements.get(keys)
        if statement is None:
            statement = self._statements[keys] = (f"INSERT INTO {self.table} ({', '.join(self.names[k] for k in keys)})"
                                                  f" VALUES ({', '.join('%s' for _ in keys)})")
        return statement, tuple(value if (process := self.processors[key]) is None else process(value)
                                for key, value in values.items())

    def _error(self, error: Exception, statement: str, params: tuple, invalidated: bool) -> DBAPIError:
        return DBAPIError.instance(statement, params, error, self.engine.dialect.loaded_dbapi.Error,
                                   connection_invalidated=invalidated, dialect=self.engine.dialect)


def new_job_row(values: dict[str, Any]) -> dict[str, Any]:
    """Every column of a new job: the values given, the columns' Python-side defaults for what is left out, None for
    the rest."""
    record = {name: None for name in COLUMN_KEYS}
    record.update(values)
    for name, default in COLUMN_DEFAULTS:
        if record[name] is None:
            record[name] = default()
    return record
