"""The one function that runs a job, shared by the embedded pool and the Celery task.

claim (conditional update: queued -> running, attempt+1, lease) -> heartbeat while the
solver runs -> store the result and artifacts, or the failure report, fenced on the attempt
number. Cancellation and lost leases reach the solver through its progress callback.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import threading
import time
import uuid
from typing import Any, Callable

from tenacity import Retrying, retry_if_exception, stop_after_delay, wait_exponential

from plantsolve.jobs import attempts, computed, intake, spool
from plantsolve.jobs.attempts import ResultPending, Stop, Verdict, failure_report, judge
from plantsolve.jobs.computed import Computed
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.jobs.lifecycle import RUNNING, SUCCEEDED, is_finished
from plantsolve.jobs.reader_notes import held, reader_warnings, reading_report, with_reader_warnings
from plantsolve.schemas.common import Report
from plantsolve.solvers.base import Artifact, Cancelled, Solved, SolverError
from plantsolve.store.models import utcnow
from plantsolve.store.repository import StoredArtifact, as_utc

log = logging.getLogger("plantsolve.runner")


class AttemptMonitor:
    """Heartbeats the lease and turns cancellation, a lost lease or the soft time limit into
    an exception raised at the solver's next progress report."""

    def __init__(self, ctx: ServiceContext, job_id: uuid.UUID, attempt: int, soft_limit: float):
        self.ctx, self.job_id, self.attempt = ctx, job_id, attempt
        self.soft_limit = soft_limit
        self.started = time.monotonic()
        self.stop_reason: str | None = None
        # the claim wrote "started": a job shorter than one write interval makes no progress write at all
        self._last_write = self.started
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._beat, name=f"heartbeat-{job_id}", daemon=True)

    def __enter__(self) -> "AttemptMonitor":
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()

    @property
    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def _beat(self) -> None:
        settings = self.ctx.settings
        while not self._done.wait(settings.heartbeat_seconds):
            try:
                if not self.ctx.repo.heartbeat(self.job_id, self.attempt, lease_seconds=settings.lease_seconds):
                    self.stop_reason = self.stop_reason or "cancelled"
                    return
            except Exception as error:  # a database hiccup must not kill the attempt; the next beat retries
                log.warning("heartbeat failed for job %s: %s", self.job_id, type(error).__name__,
                            exc_info=not is_infrastructure_failure(error))

    def progress(self, fraction: float, message: str = "") -> None:
        if self.stop_reason:
            raise Stop(self.stop_reason)
        if self.elapsed > self.soft_limit:
            self.stop_reason = "time_limit"
            raise Stop("time_limit")
        now = time.monotonic()
        if now - self._last_write < self.ctx.settings.progress_write_seconds:
            return
        self._last_write = now
        fraction = min(max(float(fraction), 0.0), 1.0) if fraction == fraction else 0.0
        try:
            still_ours = self.ctx.repo.set_progress(self.job_id, self.attempt, fraction, str(message))
        except Exception as error:  # a database hiccup must not cost the computation: skip this report
            log.warning("progress write failed for job %s: %s", self.job_id, type(error).__name__)
            return
        if not still_ours:
            self.stop_reason = "cancelled"
            raise Stop("cancelled")


def lost_worker_report(attempt: int, max_attempts: int, why: str | None = None) -> dict:
    """Report for a job whose worker is gone (killed, crashed host, out of memory); the attempts' history says
    how each attempt ended, the report how the last one did (``why``): a user whose job was killed by the kernel
    for its memory is told so, not that a worker "stopped responding"."""
    how = f" (the last: {why})" if why else ""
    if attempt >= max_attempts:
        return failure_report("worker", f"The job's worker was lost on each of {attempt} attempts{how}; giving up.")
    return failure_report("worker", f"The worker was lost{how}; the job was re-queued.")


def _call_with_deadline(function: Callable[[], Any], deadline: float | None) -> Any:
    """Run ``function``; with a deadline, in a daemon thread abandoned if it overruns.

    The embedded pool cannot kill a thread; an abandoned solver can no longer write anything
    (every write is fenced) and stops at its next progress report.
    """
    if deadline is None:
        return function()
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = function()
        except BaseException as error:  # re-raised in the caller's thread
            outcome["error"] = error

    thread = threading.Thread(target=target, name="solver", daemon=True)
    thread.start()
    thread.join(deadline)
    if thread.is_alive():
        raise Stop("time_limit")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def run_job(
    ctx: ServiceContext,
    job_id: uuid.UUID,
    *,
    worker: str,
    requeue: Callable[[uuid.UUID, str], None],
    hard_limit_in_thread: bool = True,
    time_limit_errors: tuple[type[BaseException], ...] = (),
    on_claim: Callable[[], None] | None = None,
) -> str:
    """Run one delivery of ``job_id`` (``on_claim`` is called once the attempt is claimed, before the solve). Returns what happened: the final status, ``"requeued"``,
    ``"skipped"`` (not claimable: already running elsewhere, finished or cancelled) or
    ``"stale"`` (this attempt lost the job before it could store anything). Each claimed attempt
    logs one line when it starts and one when it ends (job id, kind, attempt, duration, outcome)."""
    claimed: dict[str, Any] = {}
    started = time.monotonic()
    outcome = "crashed"
    try:
        outcome = _run_claimed(ctx, job_id, worker=worker, requeue=requeue, hard_limit_in_thread=hard_limit_in_thread,
                               time_limit_errors=time_limit_errors, claimed=claimed, on_claim=on_claim)
        return outcome
    finally:
        if claimed:
            duration = round(time.monotonic() - started, 3)
            log.log(logging.WARNING if outcome in ("failed", "crashed") else logging.INFO,
                    "job %s (%s) attempt %d: %s after %.3f s", job_id, claimed["kind"], claimed["attempt"], outcome,
                    duration, extra={"job_id": str(job_id), "kind": claimed["kind"], "attempt": claimed["attempt"],
                                     "duration_seconds": duration, "outcome": outcome, "worker": worker})


def _run_claimed(
    ctx: ServiceContext,
    job_id: uuid.UUID,
    *,
    worker: str,
    requeue: Callable[[uuid.UUID, str], None],
    hard_limit_in_thread: bool,
    time_limit_errors: tuple[type[BaseException], ...],
    claimed: dict[str, Any],
    on_claim: Callable[[], None] | None,
) -> str:
    job = ctx.repo.get(job_id)
    if job is None:
        return "skipped"
    attempt = ctx.repo.claim(job_id, lease_seconds=ctx.settings.lease_seconds, worker=worker)
    if attempt is None:
        if is_finished(job.status) and job.attempt:
            # a delivery again after the end (Celery's, of a task whose worker was killed): that worker may have
            # been killed between the commit and its clean-up
            tidy_ended(ctx, job)
        return "skipped"
    claimed.update(kind=job.kind, attempt=attempt)
    if on_claim is not None:
        on_claim()
    log.info("job %s (%s) attempt %d started", job_id, job.kind, attempt,
             extra={"job_id": str(job_id), "kind": job.kind, "attempt": attempt, "outcome": "started", "worker": worker})
    spec = ctx.spec(job.kind)
    if spec is None:
        ctx.repo.finish_failure(
            job_id, attempt, report=failure_report("dispatch", f"No solver kind {job.kind!r} in this worker."), run_seconds=0
        )
        return "failed"

    log_book = AttemptLog(job.attempts, attempt, worker)
    soft_limit, hard_limit = ctx.limits(spec)
    read: list[dict] = []  # the reader's warnings: a failure report keeps them, as a result's report does
    with AttemptMonitor(ctx, job_id, attempt, soft_limit) as monitor:
        try:
            spooled = spool.take(ctx, job_id)
            if spooled is not None:
                return _store_spooled(ctx, job_id, attempt, spooled, log_book)
            # the output of an earlier attempt's solve that was killed before its commit, if any
            output = computed.adopt(ctx.files, spec, job, attempt)
            with intake.read_stored(spec, job, ctx.files,
                                    on_request=lambda request: read.extend(_noted(ctx, job, attempt, spec, request))
                                    ) as job_input:
                if output is None:
                    solved = _call_with_deadline(
                        lambda: spec.solve(job_input, monitor.progress),
                        hard_limit if hard_limit_in_thread else None,
                    )
                    result_json, text = _checked(spec, solved)
                    output = computed.keep(ctx.files, spec, job_id, attempt, solved, result_json, text, monitor.elapsed)
                return _store_success(ctx, spec, job_id, attempt, job_input, output, monitor, log_book)
        except Exception as error:  # the retry policy decides (attempts.judge)
            verdict = judge(error, job_id=job_id, attempt=attempt, max_attempts=job.max_attempts,
                            limits=ctx.limits(spec), elapsed=monitor.elapsed, time_limit_errors=time_limit_errors,
                            model=spec.request_model)
            if verdict.outcome == "result_pending":
                log.error("job %s attempt %d: result spooled; the next attempt stores it", job_id, attempt)
            elif verdict.crash:
                log.exception("job %s attempt %d crashed", job_id, attempt)  # the traceback stays in the server log
    if read:
        verdict = dataclasses.replace(verdict, report=with_reader_warnings(verdict.report, read))
    return _conclude(ctx, job, attempt, verdict, monitor, log_book, requeue)


def _noted(ctx: ServiceContext, job, attempt: int, spec, request: Any) -> list[dict]:
    """The reader's warnings of the request just read, written into the job's report at once (fenced on the attempt):
    an attempt that ends without a word from this process (killed, out of memory, its lease lapsed) is reported by
    the lease policy, which keeps them from there."""
    warnings = reader_warnings(request, spec)
    report = with_reader_warnings(job.report or reading_report([]), warnings)
    if warnings and held(report) != held(job.report):
        try:
            ctx.repo.note_report(job.id, attempt, report)
        except Exception as error:  # the failure report of this process still carries them
            log.warning("job %s: the reader's warnings could not be written yet (%s)", job.id, type(error).__name__)
    return warnings


def _conclude(ctx: ServiceContext, job, attempt: int, verdict: Verdict, monitor: AttemptMonitor,
              log_book: "AttemptLog", requeue: Callable[[uuid.UUID, str], None]) -> str:
    """Write what the retry policy decided, fenced on the attempt: back to the queue, or failed."""
    if verdict.outcome == "cancelled":
        return "cancelled"  # by the user, or the lease went to a newer attempt: nothing of this attempt is written
    history = log_book.add(verdict.outcome, verdict.error)
    if verdict.retry:
        if ctx.repo.requeue(job.id, attempt, report=verdict.report, attempts=history,
                            grant_attempt=verdict.grant_attempt):
            requeue(job.id, job.kind)
            return "requeued"
        if verdict.outcome == "result_pending":  # spooled after the job ended (cancelled, or stored by another)
            spool.remove_if_ended(ctx, job.id)
        return "stale"
    written = ctx.repo.finish_failure(job.id, attempt, report=verdict.report, run_seconds=monitor.elapsed,
                                      attempts=history)
    if written:  # no attempt follows a failure: what earlier ones kept (this one's own too) would lie there for good
        computed.discard_superseded(ctx.files, job.id, attempt, [])
        spool.remove(ctx, job.id)
    return "failed" if written else "stale"


class AttemptLog:
    """The job's attempt history, and this attempt's entry to add when it ends."""

    def __init__(self, previous: Any, attempt: int, worker: str):
        self.previous, self.attempt, self.worker, self.started = previous, attempt, worker, utcnow()

    def add(self, outcome: str, error: str | None = None) -> list[dict]:
        return attempts.ended(self.previous, self.attempt, self.worker, outcome, error=error, started_at=self.started)


def _non_finite_paths(value: Any, path: str = "") -> list[str]:
    if isinstance(value, float):
        return [] if math.isfinite(value) else [path or "/"]
    if isinstance(value, dict):
        return [p for key, item in value.items() for p in _non_finite_paths(item, f"{path}/{key}")]
    if isinstance(value, list):
        return [p for index, item in enumerate(value) for p in _non_finite_paths(item, f"{path}/{index}")]
    return []


def _checked(spec, solved: Solved) -> tuple[dict, str]:
    """The solve's result as stored, and as JSON text; a result no job may hold is the solver's failure."""
    result = solved.result
    if not isinstance(result, spec.result_model):
        result = spec.result_model.model_validate(result)
    result_json = result.model_dump(mode="json", by_alias=True)
    try:
        text = json.dumps(result_json, allow_nan=False)
    except ValueError:
        # JSON has no NaN or infinity: a result carrying them is a solver bug, and retrying
        # the same input would give the same numbers.
        raise SolverError(
            "result", "The solver produced non-finite numbers (NaN or infinity) in its result.",
            {"paths": _non_finite_paths(result_json)[:20]},
        ) from None
    report = result_json.get("report") or {}
    if report.get("status") == "failed":
        # a solver that says in its own report that it failed has no result to offer: the job fails with that
        # report, never "succeeded" beside it
        raise SolverError(report.get("stage") or "result", report.get("message") or "The solver reported a failure.",
                          report.get("details") or {})
    return result_json, text


def _store_success(ctx: ServiceContext, spec, job_id, attempt, job_input, output: Computed, monitor: AttemptMonitor,
                   log_book: AttemptLog) -> str:
    """Render the artifacts of a solve's ``output`` (this attempt's, or one an earlier attempt kept) and store it."""
    result_json = output.result_json
    report = dict(result_json.get("report") or Report().model_dump(mode="json"))
    if report.get("status") == "ok" and report.get("warnings"):
        report["status"] = "warning"  # a warning is never hidden behind "ok"
    rendered: list[Artifact] = []
    if spec.render_artifacts is not None:
        try:
            rendered = list(spec.render_artifacts(job_input, output.solved))
        except Cancelled:
            raise
        except Exception as error:  # the result stands; the missing files are reported
            log.exception("artifacts of job %s failed", job_id)
            _warn_artifacts(report, f"Artifacts could not be rendered: {error}")
    adopted = output.attempt != attempt
    return _write_result(ctx, job_id, attempt, output.attempt, result_json, report, [], rendered,
                         output.solve_seconds + monitor.elapsed if adopted else monitor.elapsed, log_book,
                         note=f"result computed by attempt {output.attempt}" if adopted else None, output=output,
                         kept=computed.described(output))


def _warn_artifacts(report: dict, message: str) -> None:
    warnings = list(report.get("warnings") or [])
    warnings.append({"code": "artifacts_failed", "message": message, "details": {}})
    report["warnings"] = warnings
    report["status"] = "warning" if report.get("status") == "ok" else report.get("status", "warning")


def _with_report(result_json: dict, report: dict) -> dict:
    """The result as stored: its own report is the job's (an export that could not be rendered or stored is a
    warning there too), so a reader of ``/result`` alone, the CLI's output file or a client, never sees "ok" for a
    job whose report says otherwise."""
    if "report" not in result_json or result_json["report"] == report:
        return result_json
    return {**result_json, "report": report}


def _write_result(ctx: ServiceContext, job_id, attempt, computed_by: int, result_json, report,
                  stored: list[StoredArtifact], rendered: list[Artifact], run_seconds: float, log_book: AttemptLog,
                  note: str | None = None, output: Computed | None = None, kept: dict | None = None) -> str:
    """The artifacts' blobs, then the final write; retried with backoff while the blob store or the database
    is unreachable (the heartbeat keeps the lease meanwhile). If that never succeeds, the result (and the
    artifacts not stored yet) waits in the spool for the next attempt (:mod:`plantsolve.jobs.spool`). An artifact
    whose bytes a kept payload of ``output`` holds is that blob; once the result is written, the output ``kept``
    goes, and so does a spooled result (this attempt's source, or one an attempt that lost the job left)."""
    stored, waiting = list(stored), list(rendered)

    def store_all() -> bool:
        while waiting:
            artifact = waiting[0]
            try:
                blob = (output.artifact_blob(artifact) if output is not None else None) \
                    or ctx.files.put(f"{job_id}/a{computed_by}/{artifact.name}", artifact.data)
            except Exception as error:
                if is_infrastructure_failure(error):
                    raise
                log.exception("artifact %s of job %s could not be stored", artifact.name, job_id)
                _warn_artifacts(report, f"Artifact {artifact.name!r} could not be stored: {error}")
            else:
                stored.append(StoredArtifact(artifact.name, artifact.media_type, blob.size, blob.sha256, blob.key))
            waiting.pop(0)
        return ctx.repo.finish_success(job_id, attempt, result=_with_report(result_json, report), report=report,
                                       artifacts=stored, run_seconds=run_seconds,
                                       attempts=log_book.add("succeeded", note))

    retrying = Retrying(retry=retry_if_exception(is_infrastructure_failure),
                        stop=stop_after_delay(ctx.settings.result_write_seconds),
                        wait=wait_exponential(multiplier=0.05, max=5.0), reraise=True)
    try:
        written = retrying(store_all)
    except Exception as error:
        if not is_infrastructure_failure(error):
            raise
        payload = {"attempt": computed_by, "spooled_by": attempt, "result": result_json, "report": report,
                   "run_seconds": run_seconds, "artifacts": [dataclasses.asdict(a) for a in stored],
                   "unstored": [{"name": a.name, "media_type": a.media_type} for a in waiting], "kept": kept}
        spool.write(ctx, job_id, payload, waiting)
        raise ResultPending(str(error), solved_here=computed_by == attempt) from error
    if written:
        if attempt > 1:  # a spool is an earlier attempt's: a first attempt has none to look for
            spool.remove(ctx, job_id, [artifact.path for artifact in stored])
        if kept is not None:
            computed.discard(ctx.files, job_id, kept["attempt"], kept["payloads"], stored)
        computed.discard_superseded(ctx.files, job_id, attempt, stored, but=kept["attempt"] if kept else None)
    else:
        _discard_if_finished(ctx, job_id, kept)
    return "succeeded" if written else "stale"


def _discard_if_finished(ctx: ServiceContext, job_id, kept: dict | None) -> None:
    """The commit found the attempt no longer running: once the job has finished (cancelled meanwhile, or stored by
    another attempt, whose artifacts may be kept payloads), no attempt will adopt the output kept, nor one an earlier
    attempt kept, nor store a spooled result; while it runs again, the running attempt may."""
    job = ctx.repo.get(job_id, brief=True)
    if job is None or not is_finished(job.status):
        return
    artifacts = spool.result_artifacts(ctx, job)
    spool.remove(ctx, job_id, [artifact.path for artifact in artifacts])
    if kept is not None:
        computed.discard(ctx.files, job_id, kept["attempt"], kept["payloads"], artifacts)
        computed.discard_superseded(ctx.files, job_id, job.attempt, artifacts, but=kept["attempt"])


def tidy_ended(ctx: ServiceContext, job) -> None:
    """Remove what the last process of an ended ``job`` (a record) was to remove after its commit and may not have,
    killed in between: its spooled result and the outputs kept before the commit (but for the payloads its
    artifacts store). Costs an ``exists`` per spool store and per attempt when nothing is left."""
    stored = ctx.repo.artifacts(job.id) if job.status == SUCCEEDED else []
    spool.remove(ctx, job.id, [artifact.path for artifact in stored])
    computed.discard_superseded(ctx.files, job.id, job.attempt, stored)


def _store_spooled(ctx: ServiceContext, job_id, attempt, spooled: spool.Spooled, log_book: AttemptLog) -> str:
    """An earlier attempt computed the result but could not store it: store it now, without solving."""
    payload = spooled.payload
    return _write_result(ctx, job_id, attempt, payload["attempt"], payload["result"], payload["report"],
                         spooled.stored, spooled.waiting, payload["run_seconds"], log_book,
                         note=f"result computed by attempt {payload['attempt']}", kept=payload.get("kept"))


def fail_killed_at_hard_limit(ctx: ServiceContext, job_id: uuid.UUID, *, worker: str | None = None) -> bool:
    """A job's process was killed at its hard time limit (a solver deaf even to the soft limit): fail the running
    attempt now with a report, instead of retrying a job that would hang again. Fenced on the attempt that was
    running (and, given ``worker``, only when that worker held it)."""
    job = ctx.repo.get(job_id, brief=True)
    if job is None or job.status != RUNNING or (worker is not None and job.worker != worker):
        return False
    spec = ctx.spec(job.kind)
    limit = ctx.limits(spec)[1] if spec is not None else None
    report = failure_report(
        "time_limit",
        f"The solver ignored its soft time limit and was killed at the hard limit ({limit:g} s)."
        if limit else "The solver was killed at its hard time limit.",
        time_limit=limit, killed=True)
    history = attempts.ended(job.attempts, job.attempt, job.worker, "time_limit", error="killed at the hard time limit",
                             started_at=as_utc(job.attempt_started_at))
    written = ctx.repo.finish_failure(job_id, job.attempt, report=with_reader_warnings(report, held(job.report)),
                                      run_seconds=None, attempts=history)
    if written:
        computed.discard_superseded(ctx.files, job_id, job.attempt, [])
        spool.remove(ctx, job_id)
    return written


def handed_back(ctx: ServiceContext, job_id: uuid.UUID) -> bool:
    """The service stops while the job runs: give it back to the queue without counting the attempt
    (the job did not fail; the next start runs it again). Fenced on the running attempt: an attempt
    that stored its result first keeps it, and the solver, if it goes on, can write nothing more."""
    job = ctx.repo.get(job_id, brief=True)
    if job is None or job.status != RUNNING:
        return False
    history = attempts.ended(job.attempts, job.attempt, job.worker, "handed_back",
                             error="the service stopped while the job ran", started_at=as_utc(job.attempt_started_at))
    report = failure_report("worker", "The service stopped while the job ran; it was re-queued and runs again "
                            "at the next start (this attempt is not counted).")
    return ctx.repo.requeue(job_id, job.attempt, report=with_reader_warnings(report, held(job.report)),
                            attempts=history, grant_attempt=True)

