"""The lease policy: what becomes of an attempt whose worker is gone (its process died, or its lease lapsed
without a heartbeat) and of a queued job whose message may have been lost. A lost attempt is re-queued until
the job's attempt cap, then failed with a report; a result that waits to be stored gets one more attempt.
The repository only lists the rows and writes the fenced transitions decided here, so the sweepers of many
processes never double up. :mod:`plantsolve.workers.sweeper` runs :func:`sweep_once` periodically; the
embedded pool calls :func:`lose_attempt` at once when a job process dies."""

from __future__ import annotations

import logging
import signal
import uuid
from datetime import datetime, timedelta
from typing import Callable

from plantsolve.jobs import attempts, computed, spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.lifecycle import QUEUED, RUNNING, is_finished
from plantsolve.jobs.reader_notes import held, with_reader_warnings
from plantsolve.jobs.runner import lost_worker_report, tidy_ended
from plantsolve.store.blobs import LocalBlobStore
from plantsolve.store.disk import check_free_space
from plantsolve.store.models import utcnow
from plantsolve.store.repository import LapsedAttempt, as_utc

log = logging.getLogger("plantsolve.sweeper")

Enqueue = Callable[[uuid.UUID, str], None]
Pending = Callable[[], "int | None"]
# whether the worker named so is known to be gone (a transport that can tell: the embedded service knows its host's
# job processes); False when it runs or the transport cannot tell
Gone = Callable[["str | None"], bool]

# queued jobs one sweep looks at (never sent first, then the oldest): a backlog is worked off over several
# sweeps instead of loaded whole every time
SWEEP_BATCH = 1000


def lose_attempt(ctx: ServiceContext, lost: LapsedAttempt, *, why: str, lapsed_before: datetime | None = None) -> str:
    """Decide and write the fate of a lost attempt: ``"requeued"`` (the caller enqueues it), ``"failed"``, or
    ``"stale"`` (the fenced write found the attempt no longer running: it finished, was cancelled, or, with
    ``lapsed_before``, heartbeated meanwhile)."""
    previous = next((h for h in lost.attempts if h.get("attempt") == lost.attempt), {})
    # a result the attempt computed and kept before it was lost is stored by the next attempt without solving, and
    # so gets that attempt even when this one was the last
    solved = computed.kept_by(ctx.files, lost.id, lost.attempt)
    if solved:
        why += "; its result was kept, and the next attempt stores it without solving again"
    # a result this very attempt spooled (its re-queue did not get through) is granted its attempt too, once: an
    # attempt that was to store a spooled result and was lost as well is not (each grant would call for another)
    waiting = previous.get("outcome") == "result_pending" or solved or (
        lost.attempt >= lost.max_attempts and spool.spooled_by(ctx, lost.id) == lost.attempt)
    cap = lost.max_attempts + 1 if waiting and lost.attempt >= lost.max_attempts else lost.max_attempts
    # the reader's warnings, written by the lost attempt once it read its input (or by an earlier one), are kept
    report = with_reader_warnings(lost_worker_report(lost.attempt, cap, why), held(lost.report))
    history = attempts.ended(lost.attempts, lost.attempt, lost.worker,
                             "result_pending" if previous.get("outcome") == "result_pending" else "lost", error=why,
                             started_at=lost.started_at)
    if lost.attempt >= cap:
        written = ctx.repo.finish_failure(lost.id, lost.attempt, report=report, run_seconds=None, attempts=history,
                                          lapsed_before=lapsed_before)
        if written:
            computed.discard_superseded(ctx.files, lost.id, lost.attempt, [])
            spool.remove(ctx, lost.id)
        return "failed" if written else "stale"
    written = ctx.repo.requeue(lost.id, lost.attempt, report=report, attempts=history,
                               grant_attempt=cap > lost.max_attempts, lapsed_before=lapsed_before)
    return "requeued" if written else "stale"


def process_died(ctx: ServiceContext, job_id: uuid.UUID, worker: str, exitcode: int | None) -> str:
    """A job process ended without saying how its job ended (killed, out of memory, a crash in native code): if
    it held the job's running attempt, that attempt is lost now, without waiting for its lease to lapse.
    ``exitcode``: the process's (negative: the signal that killed it), None when it is not known.
    Returns ``"requeued"`` or ``"queued"`` (the caller enqueues it), ``"failed"``, or ``"none"``."""
    job = ctx.repo.get(job_id, brief=True)
    if job is None:
        return "none"
    if job.status == QUEUED:
        return "queued"  # it died before its claim
    if is_finished(job.status) and job.worker == worker:
        tidy_ended(ctx, job)  # it ended the job, and may have died before it removed what it kept or spooled
        return "none"
    if job.status != RUNNING or job.worker != worker:
        return "none"
    how = "the job process died, how is not known (its exit status was lost: the process that reports it died too)" \
        if exitcode is None else f"the job process was killed by signal {-exitcode}" if exitcode < 0 \
        else f"the job process exited with code {exitcode}"
    if exitcode == -signal.SIGKILL:
        # nothing in the service sends it but the hard time limit (reported as such) and the kill of an abandoned
        # process (whose attempt has ended): it came from outside, most often the kernel's out-of-memory killer
        how += " (SIGKILL: sent by the kernel when memory runs out, or by an operator)"
    lost = LapsedAttempt(job.id, job.kind, job.attempt, job.max_attempts, list(job.attempts or []), job.worker,
                         job.heartbeat_at, job.report, as_utc(job.attempt_started_at))
    return lose_attempt(ctx, lost, why=how)


def remove_temporaries(ctx: ServiceContext, job_id: uuid.UUID, pid: int) -> int:
    """Job process ``pid`` of ``job_id`` died without a word (killed, out of memory): the temporary files of the blob
    writes it was in the middle of (an artifact, a kept output, a spooled result) are never renamed into place, nor
    removed; in this machine's folders (the local blob store's, the spool's) they go now. Returns how many went."""
    folders = {id(store): store for store in (ctx.files, ctx.spool) if isinstance(store, LocalBlobStore)}
    return sum(store.remove_temporaries(prefix, pid) for store in folders.values()
               for prefix in (f"{job_id}/", f"{spool.PREFIX}{job_id}/"))


def abandoned(ctx: ServiceContext, job_id: uuid.UUID, worker: str, alive_seconds: float) -> bool:
    """Whether a job process named ``worker``, alive for ``alive_seconds``, holds no live attempt of ``job_id``: the job
    finished or was cancelled, another worker holds it, or it is queued again (this process's lease lapsed and the
    sweep took the attempt back: a stopped or hung process). Such a process can store nothing (every write is
    fenced); it only takes a place in the pool and, while it runs, keeps its job from starting again. A process
    younger than a lease is never judged so: it may not have claimed its job yet."""
    if alive_seconds < ctx.settings.lease_seconds:
        return False
    job = ctx.repo.get(job_id, brief=True)
    return job is None or is_finished(job.status) or job.status == QUEUED or job.worker != worker


def sweep_once(ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None, *,
               after_outage: bool = False, gone: Gone | None = None) -> bool:
    """One pass. Running attempts whose lease lapsed are lost (:func:`lose_attempt`). Queued jobs are enqueued
    again when their message never reached the broker (``enqueued_at`` unset), or when it is older than
    ``requeue_queued_after`` and the broker holds fewer messages than there are such jobs (the oldest first: a
    restarted Redis without persistence lost them). A duplicate message is harmless: the claim lets one delivery
    run.

    ``after_outage``: the previous pass could not reach the database. Nobody could heartbeat meanwhile,
    so a lapsed lease says nothing about its worker: every running attempt first gets a full lease
    from now. A live worker's next heartbeat keeps its claim (no second solve, no attempt counted); a
    dead worker's lease lapses one lease later and it is re-queued then.

    ``gone``: the transport's word that a worker no longer runs (a job process of a service that was killed and
    started again on this host): its attempt is lost now, without waiting for its lease to lapse, so the job is not
    shown running for a lease while nothing runs it.

    Returns whether lapsed leases were judged: False while the database's disk is low (:func:`heartbeats_may_fail`),
    and the caller's next pass is then one ``after_outage``."""
    requeued: list[uuid.UUID] = []
    failed = 0
    if gone is not None:
        for lost in ctx.repo.running_attempts():
            if gone(lost.worker):
                fate = lose_attempt(ctx, lost, why=f"its worker {lost.worker} is gone")
                if fate == "requeued":
                    requeued.append(lost.id)
                failed += fate == "failed"
    if after_outage:
        extended = ctx.repo.extend_leases(ctx.settings.lease_seconds)
        if extended:
            log.warning("sweeper: the database was away; %d running lease(s) extended instead of lapsing", extended)
    now = utcnow()
    refused = heartbeats_may_fail(ctx)
    for lost in [] if refused else ctx.repo.lapsed(now):
        beat = lost.heartbeat_at.isoformat() if lost.heartbeat_at else "the start"
        fate = lose_attempt(ctx, lost, why=f"no heartbeat since {beat}", lapsed_before=now)
        if fate == "requeued":
            requeued.append(lost.id)
        failed += fate == "failed"
    waiting = [(job_id, sent) for job_id, sent in
               ctx.repo.unsent(sent_before=now - timedelta(seconds=ctx.settings.requeue_queued_after),
                               limit=SWEEP_BATCH) if job_id not in requeued]
    again = requeued + [job_id for job_id, sent in waiting if not sent]
    stale = [job_id for job_id, sent in waiting if sent]
    if stale:
        held = pending() if pending is not None else None
        missing = len(stale) if held is None else max(0, ctx.repo.count_queued() - held)
        again += stale[:missing]
    sent = 0
    for job_id in dict.fromkeys(again):
        job = ctx.repo.get(job_id, brief=True)
        if job is None or job.status != QUEUED:
            continue
        try:
            enqueue(job_id, job.kind)
        except Exception:  # still no broker: the next sweep tries again
            log.warning("sweeper: enqueue of job %s failed", job_id, exc_info=True)
            continue
        ctx.repo.mark_enqueued(job_id)
        sent += 1
    if sent or failed:
        log.info("sweeper: enqueued %d again, failed %d", sent, failed)
    return not refused


def heartbeats_may_fail(ctx: ServiceContext) -> str | None:
    """Why a lapsed lease would say nothing about its worker now though the database takes the write lock (as the
    sweeper checks): the SQLite file's disk is below ``MIN_FREE_DISK_BYTES``. On a full disk SQLite still takes and
    gives back the lock, but every heartbeat meets SQLITE_FULL; sweeping the leases that lapsed meanwhile lost each
    running attempt and solved its job again once space returned. None when leases can be judged (PostgreSQL's disk
    is the server's, and a write it refuses fails the pass)."""
    if ctx.db.file is None:
        return None
    try:
        check_free_space({"database": ctx.db.file.path.parent}, ctx.store.min_free_disk_bytes)
    except OSError as error:  # DiskLow, or free space that cannot be read (a stale network mount)
        return str(error)
    return None


def resume(ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None, gone: Gone | None = None) -> None:
    """At a dispatcher's start: jobs left queued (or running with a dead lease, or a worker ``gone`` says is gone) by
    a previous process are enqueued again."""
    sweep_once(ctx, enqueue, pending, gone=gone)
    for job_id, kind in ctx.repo.queued_jobs(limit=10_000):  # a dispatcher that pulls from the database takes what it can
        enqueue(job_id, kind)
