"""The spool: a computed result whose final write did not get through, waiting for the next attempt to store it.

When the artifacts' blobs and the result's commit fail for ``RESULT_WRITE_SECONDS`` (the database or the blob store
away), the attempt writes the result and the artifacts not stored yet as blobs under ``pending/<job id>/``: in the
blob store, where every worker finds them, or, when that is away too, in this machine's folder. The next attempt
stores them without solving again and removes them.

Every other end of the job removes them too (a cancel, a failure, the lease policy's failure at the cap, the kill at
the hard time limit, another attempt's result), and so does an attempt that spooled after its job had ended (it lost
its lease, or the job was cancelled, while it waited for the database). A process killed between the commit and the
removal, or in the middle of its spool's writes, leaves blobs no end will look for: every spool lies under one
prefix, so :func:`sweep`, run once when a dispatcher starts, lists them and removes those whose job has ended.
Removing is a best effort: the job's end is written already, and a blob store that fails here leaves an orphan for
the next start's sweep, never a failed job.
"""

from __future__ import annotations

import json
import logging
import uuid
from dataclasses import dataclass
from typing import Iterable

from plantsolve.jobs import computed
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.jobs.lifecycle import SUCCEEDED, is_finished
from plantsolve.solvers.base import Artifact
from plantsolve.store.blobs import BlobMissing, BlobStore, BlobStoreUnavailable
from plantsolve.store.repository import JobRecord, StoredArtifact

log = logging.getLogger("plantsolve.runner")

PREFIX = "pending/"


def pending_path(job_id: uuid.UUID) -> str:
    """The spooled result: written last, so its presence says the artifacts it names are there."""
    return f"{PREFIX}{job_id}/result.json"


def pending_artifact_key(job_id: uuid.UUID, name: str) -> str:
    """Where an artifact of a spooled result waits that the blob store did not take."""
    return f"{PREFIX}{job_id}/artifacts/{name}"


def stores(ctx: ServiceContext) -> list[BlobStore]:
    """Where a computed result may wait: the blob store first (every worker finds it there), then this
    machine's folder (the PostgreSQL back-end is away with the database; only this machine finds it)."""
    return [ctx.files] if ctx.spool is ctx.files else [ctx.files, ctx.spool]


def holder(ctx: ServiceContext, job_id: uuid.UUID) -> BlobStore | None:
    """The store holding a result that an earlier attempt computed but could not write, if any."""
    for store in stores(ctx):
        try:
            if store.exists(pending_path(job_id)):
                return store
        except BlobStoreUnavailable:
            continue
    return None


def spooled_by(ctx: ServiceContext, job_id: uuid.UUID) -> int | None:
    """The attempt that wrote the job's spooled result, if one waits (None too when it cannot be read)."""
    store = holder(ctx, job_id)
    if store is None:
        return None
    try:
        return json.loads(store.get(pending_path(job_id))).get("spooled_by")
    except (BlobMissing, BlobStoreUnavailable, ValueError, AttributeError):
        return None


@dataclass(frozen=True)
class Spooled:
    """A spooled result as written: the ``payload`` (the attempt that computed it, result, report, run seconds, the
    output kept), the artifacts stored already and the bytes of those that wait."""

    payload: dict
    stored: list[StoredArtifact]
    waiting: list[Artifact]


def write(ctx: ServiceContext, job_id: uuid.UUID, payload: dict, waiting: list[Artifact]) -> None:
    """Spool the result in the first store that takes it; raises the last store's error when none does. A store that
    took some artifacts and then refused keeps none of them (no result there names them)."""
    error: BaseException | None = None
    for store in stores(ctx):
        written: list[str] = []
        try:
            for artifact in waiting:
                store.put(pending_artifact_key(job_id, artifact.name), artifact.data)
                written.append(pending_artifact_key(job_id, artifact.name))
            store.put(pending_path(job_id), json.dumps(payload).encode())  # last: its presence says all is there
            return
        except Exception as away:
            _delete_quietly(store, written)
            if not is_infrastructure_failure(away):
                raise
            error = away
    raise error


def _delete_quietly(store: BlobStore, keys: list[str]) -> None:
    try:
        for key in keys:
            store.delete(key)
    except Exception:  # the store that refused the write may refuse this too: the start-up sweep finds them
        log.warning("%d spooled blob(s) of a spool cut short could not be removed", len(keys), exc_info=True)


def take(ctx: ServiceContext, job_id: uuid.UUID) -> Spooled | None:
    """The spooled result that waits for this attempt, read whole; None when none waits, or when it cannot be used
    (a blob of it missing, unreadable): it is removed then, and the attempt solves again, which is always right,
    instead of failing the job as if its input had. A store that cannot be reached raises (the attempt is retried)."""
    store = holder(ctx, job_id)
    if store is None:
        return None
    try:
        payload = json.loads(store.get(pending_path(job_id)))
        stored = [StoredArtifact(**artifact) for artifact in payload["artifacts"]]
        waiting = [Artifact(a["name"], a["media_type"], store.get(pending_artifact_key(job_id, a["name"])))
                   for a in payload.get("unstored", [])]
        missing = {"attempt", "result", "report", "run_seconds"} - payload.keys()  # what the storing attempt reads
        if missing:
            raise KeyError(sorted(missing))
    except (BlobMissing, ValueError, KeyError, TypeError, AttributeError) as error:
        log.warning("job %s: its spooled result cannot be used (%s); it is solved again", job_id, type(error).__name__)
        # read again now: an attempt whose lease lapsed may find the spool half removed by the attempt that stored it,
        # and the artifacts that job's result now holds must stay
        remove(ctx, job_id, [artifact.path for artifact in result_artifacts(ctx, ctx.repo.get(job_id, brief=True))])
        return None
    return Spooled(payload, stored, waiting)


def remove(ctx: ServiceContext, job_id: uuid.UUID, in_use: Iterable[str] = ()) -> None:
    """The job has ended, or its spooled result is stored: its spool goes from every store that holds one (one
    ``exists`` each when there is none), and so do the artifacts the spooling attempt had stored already, but for
    those the job's result holds (``in_use``: their keys). The artifacts go first, the result (the index that finds
    them) last, so that a removal cut short is finished by a later one."""
    for store in stores(ctx):
        try:
            if store.exists(pending_path(job_id)):
                _remove_spool(ctx, store, job_id, [], set(in_use))
        except Exception:
            log.warning("the spooled result of job %s could not be removed", job_id, exc_info=True)


def _remove_spool(ctx: ServiceContext, store: BlobStore, job_id: uuid.UUID, found: list[str], in_use: set[str]) -> int:
    """Remove one job's spool from ``store``: the keys ``found`` under its prefix, the artifacts its result names (the
    unstored ones in this store, the stored ones in the blob store, but for ``in_use``), then the result. Returns how
    many blobs went."""
    unstored: list[str] = []
    stored: list[str] = []
    try:
        payload = json.loads(store.get(pending_path(job_id)))
        unstored = [pending_artifact_key(job_id, a["name"]) for a in payload.get("unstored", [])]
        stored = [a["path"] for a in payload.get("artifacts", [])]
    except BlobMissing:
        pass  # cut short before its result was written: ``found`` holds what there is
    except (ValueError, TypeError, KeyError, AttributeError):
        log.warning("the spooled result of job %s cannot be read; its stored artifacts stay", job_id)
    index = pending_path(job_id)
    for key in dict.fromkeys([*found, *unstored]):
        if key != index:
            store.delete(key)
    for key in stored:
        if key not in in_use:
            ctx.files.delete(key)
    store.delete(index)
    return len(set(found) | set(unstored) | {index}) + len([k for k in stored if k not in in_use])


def remove_if_ended(ctx: ServiceContext, job_id: uuid.UUID) -> bool:
    """An attempt found the job no longer its own (a fenced write refused): once the job has ended, no attempt will
    store a spooled result, so it goes. Returns whether the job has ended."""
    job = ctx.repo.get(job_id, brief=True)
    if job is not None and not is_finished(job.status):
        return False
    remove(ctx, job_id, [artifact.path for artifact in result_artifacts(ctx, job)])
    return True


def result_artifacts(ctx: ServiceContext, job: JobRecord | None) -> list:
    """The artifacts an ended job's result holds (none unless it succeeded)."""
    if job is None or job.status != SUCCEEDED:
        return []
    return ctx.repo.artifacts(job.id)


def sweep(ctx: ServiceContext) -> int:
    """Remove every spool whose job has ended or is gone, in every store this process reaches, with what it names
    (:func:`remove`); a spool whose job is queued or running stays for its next attempt. Returns how many blobs went.
    Raises when the database cannot say how a job stands (the caller tries again later); a store that cannot be
    listed or emptied is left for a later start."""
    removed = 0
    for store in stores(ctx):
        try:
            keys = list(store.keys(PREFIX))
        except BlobStoreUnavailable:
            log.warning("the spool of the %s blob store could not be listed; swept at a later start", store.kind)
            continue
        by_job: dict[uuid.UUID | None, list[str]] = {}
        for key in keys:
            by_job.setdefault(_job_of(key), []).append(key)
        for job_id, found in by_job.items():
            try:
                if job_id is None:  # no job's (a stray file under the prefix)
                    for key in found:
                        store.delete(key)
                    removed += len(found)
                    continue
                job = ctx.repo.get(job_id, brief=True)
                if job is not None and not is_finished(job.status):
                    continue
                held = result_artifacts(ctx, job)
            except BlobStoreUnavailable:
                log.warning("the spool of job %s could not be removed; swept at a later start", job_id)
                continue
            try:
                removed += _remove_spool(ctx, store, job_id, found, {artifact.path for artifact in held})
                if job is not None:  # the process killed before this clean-up left the outputs kept before a commit
                    computed.discard_superseded(ctx.files, job_id, job.attempt, held)
            except Exception:  # one spool that cannot be removed must not keep the sweep from the others
                log.warning("the spool of job %s could not be removed; swept at a later start", job_id, exc_info=True)
    if removed:
        log.info("spool: removed %d blob(s) of jobs that have ended", removed)
    return removed


def _job_of(key: str) -> uuid.UUID | None:
    """The job a spooled key belongs to (None: no job's, a stray file under the prefix, removed too)."""
    try:
        return uuid.UUID(key[len(PREFIX):].split("/", 1)[0])
    except ValueError:
        return None
