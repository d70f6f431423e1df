"""The job service: submission (intake, idempotency, the input stored, enqueue after commit), reads,
cancellation, result operations and the views the API returns. No HTTP here: it raises the job
domain's errors (:mod:`plantsolve.jobs.errors`), which the app renders as problem documents."""

from __future__ import annotations

import asyncio
import base64
import binascii
import hashlib
import json
import logging
import re
import uuid
from concurrent.futures import Future
from dataclasses import dataclass
from datetime import datetime
from typing import Any, Callable, Iterable, Mapping

from plantsolve.jobs import attempts, computed, intake, spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.dispatch import Dispatcher
from plantsolve.jobs.errors import Conflict, DiskSpaceLow, NotFound, Unprocessable, field_problem, from_input_rejected
from plantsolve.jobs.holds import DISK_WAIT, disk_low
from plantsolve.jobs.lifecycle import CANCELLED, QUEUED, RUNNING, SUCCEEDED, is_finished
from plantsolve.jobs.runner import failure_report
from plantsolve.schemas.common import verdicts_of
from plantsolve.schemas.jobs import ArtifactInfo, AttemptInfo, CallbackInfo, JobList, JobProgress, JobTimings, JobView
from plantsolve.solvers.base import InputRejected, ResultNotUsable, ResultOperation, SolverSpec, StoredInput
from plantsolve.store.blobs import BlobMissing, BlobReader
from plantsolve.store.models import utcnow
from plantsolve.store.repository import JobRecord
from plantsolve.store.repository import JobState, as_utc

log = logging.getLogger("plantsolve.api")


@dataclass
class NewJob:
    """A submission read and checked, not stored yet: its row's columns but the defaults."""

    spec: SolverSpec
    job_id: uuid.UUID
    body_hash: str
    idempotency_key: str | None
    fields: dict[str, Any]
    owner: str = ""


@dataclass
class Submitted:
    job: JobRecord
    created: bool
    view: JobView | None = None


def safe_filename(name: str) -> str:
    base = re.sub(r"[^A-Za-z0-9._-]+", "_", name.rsplit("/", 1)[-1].rsplit("\\", 1)[-1]).strip("._")
    return base[:120] or "upload"


CANCEL_TRIES = 20  # reads and conditional writes of a cancel, each lost only to another transition of the job


class JobService:
    def __init__(self, ctx: ServiceContext, dispatcher: Dispatcher, readers: Iterable[SolverSpec] | None = None,
                 reader_start: str = "forkserver"):
        """``readers``: the kinds whose uploads this service reads (their readers are imported ahead, in the
        forkserver that reading processes fork from); every kind of the map by default. ``reader_start``
        ``"fork"``: reading processes fork from this process instead (one with a single thread: the CLI's)."""
        self.ctx = ctx
        self.dispatcher = dispatcher
        self._intake_loaded: set[str] = set()
        self._reader_start = reader_start
        if reader_start == "forkserver":
            intake.start_readers(ctx.kinds.values() if readers is None else readers)

    @property
    def kinds(self) -> Mapping[str, SolverSpec]:
        return self.ctx.kinds

    # ---- submission ---------------------------------------------------------------------

    def spec(self, kind: str) -> SolverSpec:
        spec = self.ctx.spec(kind)
        if spec is None:
            raise NotFound(f"No solver kind {kind!r}. Known kinds: {', '.join(sorted(self.ctx.kinds))}.")
        return spec

    def with_view(self, submit: Callable[..., Submitted], *args: Any, **kwargs: Any) -> Submitted:
        """``submit(*args, **kwargs)`` (a submission method of this service) plus the job's view: one thread hop for
        an async route."""
        submitted = submit(*args, **kwargs)
        submitted.view = self.view(submitted.job)
        return submitted

    def submit_json(self, kind: str, body: bytes, idempotency_key: str | None, *, owner: str = "",
                    callback_url: str | None = None) -> Submitted:
        return self.store(self.take_json(kind, body, idempotency_key, owner=owner, callback_url=callback_url))

    def take_json(self, kind: str, body: bytes, idempotency_key: str | None, *, owner: str = "",
                  callback_url: str | None = None) -> NewJob:
        """A JSON submission read, checked and ready to store (a large request's input stored as a file already).

        A large request (more than ``INLINE_INPUT_BYTES``) is stored as it came and read and checked from its file in
        a bounded process, as an upload is: this process holds its bytes, never the objects made of them."""
        spec = self.spec(kind)
        self.has_room(idempotency_key, owner, read_bounded=not self.stores_inline(len(body)))
        job_id = uuid.uuid4()
        if not self.stores_inline(len(body)):
            blob = self.ctx.files.put(f"{job_id}/input/request.json", body)
            try:
                with self.ctx.files.local_file(blob.key, "request.json") as path:
                    body_hash = intake.read_json_bounded(spec, StoredInput.from_path(path, "request.json"),
                                                         self.ctx.settings.plugins, start=self._reader_start)
            except Exception:
                self.ctx.files.delete(blob.key)
                raise
            fields: dict[str, Any] = {"input_kind": "json_file", "input_file": blob.key}
        else:
            raw, job_input = intake.read_json(spec, body)
            intake.check(spec, job_input)
            self._intake_loaded.add(kind)
            body_hash = intake.body_hash(kind, raw)
            fields = {"input_kind": "json", "input": raw}
        return NewJob(spec, job_id, body_hash, idempotency_key, {**fields, **_callback(callback_url)}, owner)

    def has_room(self, idempotency_key: str | None = None, owner: str = "", *, read_bounded: bool = False) -> None:
        """Raise :class:`DiskSpaceLow` (503) while the service's disk is below ``MIN_FREE_DISK_BYTES``: a submission
        then is refused, as readiness says ``disk``, rather than taken while no job starts
        (:mod:`plantsolve.jobs.holds`) or into a store that may not hold it. A repeated request whose
        ``idempotency_key`` names a stored job stores nothing new: it is answered with that job (or its conflict).

        ``read_bounded``: the submission is to be read in a bounded process. While their forkserver's starts are paused
        it raises :class:`~plantsolve.jobs.errors.ReadersPaused` (503, ``Retry-After`` the pause left) now, before the
        submission is hashed and stored only to be deleted."""
        if read_bounded and self._reader_start == "forkserver":
            intake.FORKSERVER_STARTS.refuse_while_paused()
        why = disk_low(self.ctx)
        if why is None:
            return
        if idempotency_key is not None:
            if self.ctx.repo.get_by_idempotency_key(_stored_key(owner, idempotency_key)) is not None:
                return
        log.warning("submission refused: %s", why)
        raise DiskSpaceLow()

    def intake_loaded(self, kind: str) -> bool:
        """Whether this process has read a JSON submission of ``kind`` (so the kind's checks, imported on first use,
        are loaded: reading another costs microseconds, not an import)."""
        return kind in self._intake_loaded

    def stores_inline(self, size: int) -> bool:
        """Whether a JSON request of ``size`` bytes is kept in the job row (else :meth:`take_json` writes it to the
        blob store)."""
        return size <= self.ctx.settings.inline_input_bytes

    def submit_upload(
        self, kind: str, filename: str, content: bytes, options_text: str | None, idempotency_key: str | None,
        *, owner: str = "", callback_url: str | None = None,
    ) -> Submitted:
        spec = self.spec(kind)
        extension = intake.upload_extension(spec, filename)
        options = intake.upload_options(options_text)
        if not content:
            intake.read_upload(spec, StoredInput.from_bytes(filename, content), options)  # the 422 of an empty file
        intake.check_text_lines(StoredInput.from_bytes(filename, content))
        digest = hashlib.sha256()
        for part in (kind.encode(), extension.encode(), intake.canonical_json(options), content):
            digest.update(hashlib.sha256(part).digest())
        if idempotency_key is not None:  # a repeated request is answered with its job: its upload is not stored again
            existing = self.ctx.repo.get_by_idempotency_key(_stored_key(owner, idempotency_key))
            if existing is not None:
                return self.stored(NewJob(spec, existing.id, digest.hexdigest(), idempotency_key, {}, owner),
                                   existing, False)
        self.has_room(read_bounded=True)  # the key, if any, names no job: this request would store its upload
        job_id = uuid.uuid4()
        # stored first: the upload is read (and checked) from its file, in a bounded process, not in this one
        blob = self.ctx.files.put(f"{job_id}/input/{safe_filename(filename)}", content)
        try:
            with self.ctx.files.local_file(blob.key, filename) as path:
                intake.read_upload_bounded(spec, StoredInput.from_path(path, filename), options,
                                           self.ctx.settings.plugins, start=self._reader_start)
        except Exception:
            self.ctx.files.delete(blob.key)
            raise
        fields = {"input_kind": "upload", "input_file": blob.key, "input_filename": filename, "input_options": options,
                  **_callback(callback_url)}
        return self.store(NewJob(spec, job_id, digest.hexdigest(), idempotency_key, fields, owner))

    def store(self, new: NewJob) -> Submitted:
        """Store a submission (or find the job its idempotency key names) and, once committed, hand it to the
        queue."""
        submitted = self.stored(new, *self.ctx.repo.create(self._columns(new)))
        if submitted.created:
            self.dispatch(submitted.job)
        return submitted

    @property
    def stores_on_loop(self) -> bool:
        """Whether :meth:`store_on_loop` may be awaited: the store writes a new job on the event loop and the queue
        takes it there (PostgreSQL and Redis)."""
        return self.ctx.repo.creates_on_loop and getattr(self.dispatcher, "enqueues_on_loop", False)

    async def store_on_loop(self, new: NewJob) -> Submitted:
        """:meth:`store` awaited on the running event loop, no thread: the row is committed, then the job handed to
        the queue (a hand-over that fails leaves the job to the sweeper, as in :meth:`dispatch`). A new job comes
        with its view (made while the queue answers the hand-over: it reads nothing); an existing one's is left to
        the caller (it may read the job's artifacts)."""
        submitted = self.stored(new, *await self.ctx.repo.create_on_loop(self._columns(new)))
        if submitted.created:
            def with_view() -> None:
                submitted.view = self.view(submitted.job)

            try:
                await self.dispatcher.enqueue_on_loop(submitted.job.id, submitted.job.kind, meanwhile=with_view)
            except Exception:
                log.warning("enqueue of job %s failed; the sweeper will send it", submitted.job.id, exc_info=True)
                await asyncio.to_thread(self.ctx.repo.clear_enqueued, submitted.job.id)
            if submitted.view is None:  # the hand-over failed before it was written
                with_view()
        return submitted

    def store_later(self, new: NewJob) -> Future | None:
        """Store a submission through the store's group commit: a future of what :meth:`stored` takes, answered once
        the row is committed; None when the store writes each submission itself (then call :meth:`store`). The
        caller hands a new job to the queue (:meth:`dispatch`) after the commit."""
        return self.ctx.repo.create_later(self._columns(new))

    def stored(self, new: NewJob, stored: JobRecord, created: bool) -> Submitted:
        """The outcome of storing ``new``: the new job, or the job of the same idempotency key (the same request:
        200; another: 422). The input file a repeated request wrote (a large JSON body, read from it) is removed:
        the job it names has its own."""
        if not created:
            self._drop_input(new)
            if stored.body_hash != new.body_hash or stored.kind != new.spec.kind:
                raise Unprocessable(
                    "This Idempotency-Key was already used with a different request.",
                    errors=[field_problem(["header", "Idempotency-Key"], "already used with a different body", "idempotency_conflict")],
                )
            return Submitted(stored, False)
        log.info("job %s (%s) submitted", stored.id, stored.kind,
                 extra={"job_id": str(stored.id), "kind": stored.kind, "status": QUEUED.value})
        return Submitted(stored, True)

    def _drop_input(self, new: NewJob) -> None:
        key = new.fields.get("input_file")
        if key:
            try:
                self.ctx.files.delete(key)
            except Exception:  # the answer stands; a file left behind is the store's leftover, not the client's
                log.warning("input %s of a repeated request was not removed", key, exc_info=True)

    @property
    def dispatches_at_once(self) -> bool:
        """Whether handing a job to the queue returns at once (an in-process queue, no broker across the network):
        then an event loop may do it."""
        return getattr(self.dispatcher, "in_process", False)

    def dispatch(self, job: JobRecord) -> None:
        """Hand a committed new job to the queue (only after the commit: a worker must always find the job)."""
        try:
            self.dispatcher.enqueue(job.id, job.kind)
        except Exception:  # the broker is down: the row is safe; unmarked, the next sweep sends it
            log.warning("enqueue of job %s failed; the sweeper will send it", job.id, exc_info=True)
            self.ctx.repo.clear_enqueued(job.id)

    def _columns(self, new: NewJob) -> dict[str, Any]:
        owner, key = new.owner, new.idempotency_key
        return dict(
            id=new.job_id,
            kind=new.spec.kind,
            status=QUEUED,
            attempt=0,
            max_attempts=new.spec.max_attempts or self.ctx.settings.max_attempts,
            progress=0.0,
            progress_message="queued",
            idempotency_key=_stored_key(owner, key),
            owner=owner,
            body_hash=new.body_hash,
            solver_version=new.spec.version,
            enqueued_at=utcnow(),  # enqueued right after the commit; cleared if that fails
            **new.fields,
        )

    # ---- reads and cancel -------------------------------------------------------------------

    def get(self, job_id: uuid.UUID, sees: str | None = None, *, brief: bool = False) -> JobRecord:
        """The job, if the caller may see it (``sees``: the caller's tenant, None for all); ``brief``
        without its input and result (enough for its view)."""
        job = self.ctx.repo.get(job_id, brief=brief)
        if job is None or (sees is not None and job.owner != sees):
            raise NotFound(f"No job {job_id}.")
        return job

    @property
    def reads_on_loop(self) -> bool:
        """Whether :meth:`view_on_loop` may be awaited (the store reads on the event loop: PostgreSQL)."""
        return self.ctx.repo.reads_on_loop

    async def view_on_loop(self, job_id: uuid.UUID, sees: str | None = None) -> JobView:
        """The view of :meth:`get` (brief) awaited on the running event loop, no thread."""
        job, artifacts = await self.ctx.repo.get_brief_on_loop(job_id)
        if job is None or (sees is not None and job.owner != sees):
            raise NotFound(f"No job {job_id}.")
        return self.view(job, artifacts=artifacts)

    def state(self, job_id: uuid.UUID) -> JobState | None:
        """The job's status and progress alone (what an event stream polls)."""
        return self.ctx.repo.state(job_id)

    def states(self, **filters: Any) -> list[JobState]:
        """Status and progress of the jobs created since ``since`` or named in ``ids`` (see the repository)."""
        return self.ctx.repo.states(**filters)

    def search(self, *, kind: str | None, status: str | None, text: str | None, after: tuple | None, limit: int,
               sees: str | None) -> list[JobRecord]:
        """A page of jobs the caller may see, newest first, filtered by kind, status and a text (without their
        inputs and results: enough for their views)."""
        return self.ctx.repo.list(kind=kind, status=status, text=text, after=after, limit=limit, owner=sees, brief=True)

    def count_by_status(self, sees: str | None) -> dict[str, int]:
        return self.ctx.repo.count_by_status(owner=sees)

    def input_file(self, job: JobRecord) -> BlobReader:
        """A job's stored input file (an upload, or a large JSON request), opened from the blob store: its
        ``size`` and ``chunks()`` (read once), or ``close()``. A blob store that cannot be reached raises a
        ``ConnectionError`` (503) here, before a response starts."""
        return self._open(job.input_file, f"The input file of job {job.id} is missing from the blob store.")

    def artifact(self, job_id: uuid.UUID, name: str, sees: str | None = None) -> tuple[Any, BlobReader]:
        """An artifact of a job the caller may see (name, media type, size, SHA-256) and its file, opened."""
        self.get(job_id, sees, brief=True)
        artifact = self.ctx.repo.artifact(job_id, name)
        if artifact is None:
            raise NotFound(f"Job {job_id} has no artifact {name!r}.")
        return artifact, self._open(artifact.path, f"The file of artifact {name!r} of job {job_id} is missing from "
                                                   "the blob store.")

    def _open(self, key: str | None, missing: str) -> BlobReader:
        if not key:
            raise NotFound(missing)
        try:
            return self.ctx.files.open(key)
        except BlobMissing:
            raise NotFound(missing) from None

    # ---- what the metrics and the completion webhooks read and record ------------------------

    # the metrics' reads: ``sees`` as elsewhere (None: every tenant)

    def count_by_kind_status(self, sees: str | None = None) -> list[tuple[str, str, int]]:
        return self.ctx.repo.count_by_kind_status(owner=sees)

    def oldest_queued(self, sees: str | None = None) -> list[tuple[str, Any]]:
        return self.ctx.repo.oldest_queued(owner=sees)

    def run_time_histogram(self, buckets: tuple[float, ...], sees: str | None = None) -> list[tuple]:
        return self.ctx.repo.run_time_histogram(buckets, owner=sees)

    def due_callbacks(self) -> list[uuid.UUID]:
        return self.ctx.repo.due_callbacks()

    def claim_callback(self, job_id: uuid.UUID, *, lease_seconds: float) -> int | None:
        return self.ctx.repo.claim_callback(job_id, lease_seconds=lease_seconds)

    def record_callback(self, job_id: uuid.UUID, attempt: int, **outcome: Any) -> bool:
        return self.ctx.repo.record_callback(job_id, attempt, **outcome)

    def cancel(self, job_id: uuid.UUID, sees: str | None = None) -> JobRecord:
        """Cancel a queued or running job; a running attempt ends in the history as ``cancelled``, like every
        attempt (its process notices at its next fenced write, or is killed as abandoned, and writes nothing)."""
        for _ in range(CANCEL_TRIES):
            job = self.get(job_id, sees, brief=True)
            if job.status == CANCELLED:
                return job  # a repeated cancel (its first answer lost) is answered as the first was
            if is_finished(job.status):
                raise Conflict(f"Job {job_id} has already finished ({job.status}); it cannot be cancelled.",
                               extra={"status": job.status})
            history = attempts.ended(job.attempts, job.attempt, job.worker, "cancelled",
                                     started_at=as_utc(job.attempt_started_at)) if job.status == RUNNING else None
            outcome = self.ctx.repo.cancel(job_id, report=failure_report("cancelled", "Cancelled on request."),
                                           attempts=history, seen=(job.status, job.attempt))
            if outcome is None:
                raise NotFound(f"No job {job_id}.")
            if outcome == CANCELLED:
                computed.discard_superseded(self.ctx.files, job_id, job.attempt, [])
                if job.attempt:  # an attempt may have spooled its result for the next one, which will not come
                    spool.remove(self.ctx, job_id)
                return self.get(job_id, brief=True)
            # claimed, lost, re-queued or finished between the read and the write: read it again
        raise Conflict(f"Job {job_id} changed state {CANCEL_TRIES} times while it was being cancelled; try again.",
                       extra={"status": outcome})

    def result(self, job_id: uuid.UUID, sees: str | None = None, *, kind: str | None = None) -> Any:
        """The result of a succeeded job; ``kind``: only a job of that kind (404 for another)."""
        job = self.get(job_id, sees)
        if kind is not None and job.kind != kind:
            raise NotFound(f"Job {job_id} is a {job.kind!r} job, not a {kind!r} job.")
        if job.status != SUCCEEDED:
            if is_finished(job.status):
                raise Conflict(
                    f"Job {job_id} {job.status}; it has no result. See its report.",
                    extra={"status": job.status, "report": job.report},
                )
            raise Conflict(f"Job {job_id} is {job.status}; the result is not ready yet.", extra={"status": job.status})
        return job.result

    def answer(self, spec: SolverSpec, operation: ResultOperation, job_id: uuid.UUID, body: Any,
               sees: str | None = None) -> Any:
        """A kind's synchronous result operation (e.g. perfmap's inverse query) on a finished job."""
        job = self.get(job_id, sees)
        if job.kind != spec.kind:
            raise NotFound(f"Job {job_id} is a {job.kind!r} job, not a {spec.kind!r} job.")
        if job.status != SUCCEEDED:
            raise Conflict(
                f"Job {job_id} is {job.status}; only a succeeded {spec.kind} job can answer '{operation.name}'.",
                extra={"status": job.status},
            )
        result = spec.result_model.model_validate(job.result)
        try:
            return operation.answer(result, body)
        except ResultNotUsable as error:
            raise Conflict(f"Job {job_id} {error}") from None
        except InputRejected as error:
            raise from_input_rejected(error, model=operation.request_model) from None

    def list(self, kind: str | None, status: str | None, cursor: str | None, limit: int,
             sees: str | None = None) -> JobList:
        after = decode_cursor(cursor) if cursor else None
        jobs = self.ctx.repo.list(kind=kind, status=status, after=after, limit=limit + 1, owner=sees)
        more = len(jobs) > limit
        jobs = jobs[:limit]
        next_cursor = encode_cursor(jobs[-1]) if more and jobs else None
        return JobList(items=[self.view(job, with_artifacts=False) for job in jobs], next_cursor=next_cursor)

    def view(self, job: JobRecord, *, with_artifacts: bool = True, artifacts: Iterable[Any] | None = None) -> JobView:
        """The job's view; ``artifacts``: the succeeded job's, read already (else read here)."""
        created, started, finished = as_utc(job.created_at), as_utc(job.started_at), as_utc(job.finished_at)
        base = f"/v1/jobs/{job.id}"
        listed = []
        if with_artifacts and job.status == SUCCEEDED:
            listed = [
                ArtifactInfo(name=a.name, media_type=a.media_type, size=a.size, sha256=a.sha256, url=f"{base}/artifacts/{a.name}")
                for a in (self.ctx.repo.artifacts(job.id) if artifacts is None else artifacts)
            ]
        links = {"self": base, "result": f"{base}/result", "cancel": f"{base}/cancel", "input": f"{base}/input"}
        return JobView(
            id=job.id,
            kind=job.kind,
            status=job.status,
            attempt=job.attempt,
            max_attempts=job.max_attempts,
            progress=JobProgress(fraction=job.progress, message=job.progress_message or ""),
            timings=JobTimings(
                created_at=created,
                started_at=started,
                finished_at=finished,
                queued_seconds=(started - created).total_seconds() if started else None,
                run_seconds=job.run_seconds,
            ),
            solver_version=job.solver_version,
            idempotency_key=(job.idempotency_key[len(job.owner) + 1:]
                             if job.owner and job.idempotency_key else job.idempotency_key),
            summary=_summary(job),
            report=job.report,
            artifacts=listed,
            attempts=[AttemptInfo.model_validate(h) for h in (job.attempts or [])],
            links=links,
            callback=(CallbackInfo(url=job.callback_url, state=job.callback_state, attempts=job.callback_attempts or 0,
                                   error=job.callback_error) if job.callback_url and job.callback_state else None),
        )


def _stored_key(owner: str, key: str | None) -> str | None:
    """An idempotency key as the store keeps it: each tenant's keys apart."""
    return f"{owner}:{key}" if key is not None and owner else key


def _callback(url: str | None) -> dict[str, Any]:
    """The job columns of a completion webhook: due as soon as the job has finished."""
    if url is None:
        return {}
    return {"callback_url": url, "callback_state": "pending", "callback_attempts": 0, "callback_next_at": utcnow()}


def _summary(job: JobRecord) -> str:
    report = job.report or {}
    if job.status == QUEUED and job.progress_message == DISK_WAIT:
        return ("Waiting: disk space low. The service starts no job while its disk is below MIN_FREE_DISK_BYTES; this "
                "one stays queued and starts once space is freed.")
    if job.status == QUEUED:
        return "Waiting for a worker." if job.attempt == 0 else f"Re-queued after attempt {job.attempt}: {report.get('message', '')}"
    if job.status == RUNNING:
        return f"Running (attempt {job.attempt}): {job.progress_message} ({job.progress:.0%})."
    if job.status == SUCCEEDED:
        warnings = report.get("warnings") or []
        head = next(iter(verdicts_of(warnings)), None)
        if head is not None:  # "succeeded" alone reads as a pass
            return f"Finished, but the result does not pass: {head.label} [{head.code}]: {head.message}"
        return report.get("message") or ("Succeeded" + (f" with {len(warnings)} warning(s)." if warnings else "."))
    return report.get("message") or job.status.capitalize() + "."


def encode_cursor(job: JobRecord) -> str:
    payload = json.dumps([as_utc(job.created_at).isoformat(), str(job.id)]).encode()
    return base64.urlsafe_b64encode(payload).decode().rstrip("=")


def decode_cursor(cursor: str) -> tuple[datetime, uuid.UUID]:
    try:
        padded = cursor + "=" * (-len(cursor) % 4)
        created, job_id = json.loads(base64.urlsafe_b64decode(padded))
        return as_utc(datetime.fromisoformat(created)), uuid.UUID(job_id)
    except (ValueError, TypeError, binascii.Error, json.JSONDecodeError):
        raise Unprocessable(
            "The cursor is not one this API returned.", errors=[field_problem(["query", "cursor"], "invalid cursor", "value_error")]
        ) from None
