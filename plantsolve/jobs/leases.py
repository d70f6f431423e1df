"""The lease policy: what becomes of a job whose worker stopped heartbeating (its lease lapsed) or
whose queue message may have been lost. Re-queued until its attempt cap, then failed with a report;
a result that waits to be stored gets one more attempt. Every change is a conditional update of
the lifecycle, so the sweepers of many processes never double up. :mod:`plantsolve.workers.sweeper`
runs :func:`sweep_once` periodically."""

from __future__ import annotations

import logging
import uuid
from typing import Callable

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.lifecycle import QUEUED
from plantsolve.jobs.runner import lost_worker_report, pending_holder

log = logging.getLogger("plantsolve.sweeper")

Enqueue = Callable[[uuid.UUID, str], None]
Pending = Callable[[], "int | None"]


def sweep_once(ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None, *,
               after_outage: bool = False) -> None:
    """One pass. Queued jobs are enqueued again when their message never reached the broker
    (``enqueued_at`` unset), or when it is older than ``requeue_queued_after`` and the broker holds
    fewer messages than there are such jobs (the oldest first: a restarted Redis without persistence
    lost them). A duplicate message is harmless: the claim lets one delivery run.

    ``after_outage``: the previous pass could not reach the database. Nobody could heartbeat meanwhile,
    so a lapsed lease says nothing about its worker: every running attempt first gets a full lease
    from now. A live worker's next heartbeat keeps its claim (no second solve, no attempt counted); a
    dead worker's lease lapses one lease later and it is re-queued then."""
    if after_outage:
        extended = ctx.repo.extend_leases(ctx.settings.lease_seconds)
        if extended:
            log.warning("sweeper: the database was away; %d running lease(s) extended instead of lapsing", extended)
    outcome = ctx.repo.sweep(requeue_queued_after=ctx.settings.requeue_queued_after,
                             report_for_lost=lost_worker_report,
                             result_waiting=lambda job_id: pending_holder(ctx, job_id) is not None)
    again = list(outcome.requeued) + [job_id for job_id, sent in outcome.waiting if not sent]
    stale = [job_id for job_id, sent in outcome.waiting if sent]
    if stale:
        held = pending() if pending is not None else None
        missing = len(stale) if held is None else max(0, ctx.repo.count_queued() - held)
        again += stale[:missing]
    sent = 0
    for job_id in dict.fromkeys(again):
        job = ctx.repo.get(job_id)
        if job is None or job.status != QUEUED:
            continue
        try:
            enqueue(job_id, job.kind)
        except Exception:  # still no broker: the next sweep tries again
            log.warning("sweeper: enqueue of job %s failed", job_id, exc_info=True)
            continue
        ctx.repo.mark_enqueued(job_id)
        sent += 1
    if sent or outcome.failed:
        log.info("sweeper: enqueued %d again, failed %d", sent, len(outcome.failed))


def resume(ctx: ServiceContext, enqueue: Enqueue, pending: Pending | None = None) -> None:
    """At a dispatcher's start: jobs left queued (or running with a dead lease) by a previous process are
    enqueued again."""
    sweep_once(ctx, enqueue, pending)
    for job_id, kind in ctx.repo.queued_jobs(limit=10_000):  # a dispatcher that pulls from the database takes what it can
        enqueue(job_id, kind)
