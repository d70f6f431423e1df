"""A solve's output kept in the blob store between the solve and its result's commit, so that nothing is solved twice.

Right after the solve, the attempt writes its result (and the payloads only the solve could make, ``Solved.files``)
as blobs keyed by the job and the attempt; then it renders and stores the artifacts and makes the one fenced commit.
A process killed in between (an operator's kill, the kernel's out-of-memory killer, a lost host) leaves that output
behind, and the next attempt adopts it instead of solving again: it renders and stores the artifacts and commits.
The result blob is written last, so its presence says the payloads are there too.

What it costs a job that is not killed: one blob of the result's JSON (the text the runner already made to check
it for NaN), deleted again once the commit holds the result. A payload that an artifact stores as it is (dedup's
optimized model) becomes that artifact's blob, so it is written once. Keeping is a best effort: a blob store that
does not take it costs the job nothing but this protection.
"""

from __future__ import annotations

import json
import logging
import uuid
from dataclasses import dataclass, field
from typing import Any, Iterable

from pydantic import ValidationError

from plantsolve.jobs.errors import is_infrastructure_failure
from plantsolve.solvers.base import Artifact, SolverSpec, Solved
from plantsolve.store.blobs import BlobMissing, BlobStore, BlobStoreUnavailable, StoredBlob, digest
from plantsolve.store.repository import JobRecord, StoredArtifact

log = logging.getLogger("plantsolve.runner")


def result_key(job_id: uuid.UUID, attempt: int) -> str:
    # beside the attempt's artifacts (``a<n>/<name>``); a leading dot keeps it apart from every artifact name
    return f"{job_id}/a{attempt}/.computed.json"


def payload_key(job_id: uuid.UUID, attempt: int, name: str) -> str:
    return f"{job_id}/a{attempt}/.computed-{name}"


@dataclass(frozen=True)
class Computed:
    """A solve's output: the ``attempt`` that solved, its result as stored (``result_json``), the ``solved`` value the
    artifacts are rendered from, how long the solve took, and the payloads kept as blobs (by name)."""

    attempt: int
    result_json: dict
    solved: Solved
    solve_seconds: float
    payloads: dict[str, StoredBlob] = field(default_factory=dict)
    kept: bool = False  # whether the result blob is there (to delete once the commit holds the result)

    def artifact_blob(self, artifact: Artifact) -> StoredBlob | None:
        """The kept payload holding exactly ``artifact``'s bytes, if any: stored already, not written again."""
        blob = self.payloads.get(artifact.name)
        if blob is None or blob.size != len(artifact.data) or self.solved.files.get(artifact.name) != artifact.data:
            return None
        return blob


def keep(files: BlobStore, spec: SolverSpec, job_id: uuid.UUID, attempt: int, solved: Solved, result_json: dict,
         result_text: str, solve_seconds: float) -> Computed:
    """Write the solve's output (payloads first, the result last) into the blob store ``files``; ``result_text`` is
    ``result_json`` as JSON. A store that refuses it is logged and the output is returned unkept."""
    payloads: dict[str, StoredBlob] = {}
    try:
        for name, data in solved.files.items():
            payloads[name] = files.put(payload_key(job_id, attempt, name), data)
        head = json.dumps({"attempt": attempt, "solver_version": spec.version, "solve_seconds": solve_seconds,
                           "payloads": sorted(payloads)})
        files.put(result_key(job_id, attempt), f'{head[:-1]}, "result": {result_text}}}'.encode())
    except Exception as error:
        log.warning("job %s attempt %d: the computed result could not be kept before its commit (%s); a kill before "
                    "the commit would cost a second solve", job_id, attempt, type(error).__name__,
                    exc_info=not is_infrastructure_failure(error))
        return Computed(attempt, result_json, solved, solve_seconds, payloads, kept=False)
    return Computed(attempt, result_json, solved, solve_seconds, payloads, kept=True)


def adopt(files: BlobStore, spec: SolverSpec, job: JobRecord, attempt: int) -> Computed | None:
    """The output an earlier attempt of ``job`` kept and never committed (the newest, by the same solver version), or
    None. Looks at nothing on a first attempt."""
    for earlier in range(attempt - 1, 0, -1):
        try:
            if not files.exists(result_key(job.id, earlier)):
                continue
            kept = json.loads(files.get(result_key(job.id, earlier)))
            if kept.get("solver_version") != spec.version:
                log.info("job %s: attempt %d's result was computed by solver version %r, not %r: solved again",
                         job.id, earlier, kept.get("solver_version"), spec.version)
                return None
            payloads = {name: files.get(payload_key(job.id, earlier, name)) for name in kept["payloads"]}
            result = spec.result_model.model_validate(kept["result"])
        except (BlobMissing, BlobStoreUnavailable, ValueError, KeyError, TypeError, ValidationError) as error:
            # gone meanwhile, unreadable or of another result model: solving again is always right
            log.warning("job %s: attempt %d's kept result cannot be used (%s); solved again", job.id, earlier,
                        type(error).__name__)
            return None
        stored = {name: StoredBlob(payload_key(job.id, earlier, name), len(data), digest(data))
                  for name, data in payloads.items()}
        return Computed(earlier, kept["result"], Solved(result, payloads), float(kept["solve_seconds"]), stored,
                        kept=True)
    return None


def kept_by(files: BlobStore, job_id: uuid.UUID, attempt: int) -> bool:
    """Whether ``attempt`` of the job kept a computed result (a lost attempt's: the next one stores it without
    solving). A blob store that cannot tell counts as no."""
    try:
        return files.exists(result_key(job_id, attempt))
    except BlobStoreUnavailable:
        return False


def discard(files: BlobStore, job_id: uuid.UUID, attempt: int, payloads: Iterable[str],
            stored: Iterable[StoredArtifact]) -> None:
    """The commit holds the result: the kept output goes, but for the payloads an artifact now stores."""
    in_use = {artifact.path for artifact in stored}
    try:
        files.delete(result_key(job_id, attempt))
        for name in payloads:
            if payload_key(job_id, attempt, name) not in in_use:
                files.delete(payload_key(job_id, attempt, name))
    except Exception:
        log.warning("the kept result of job %s could not be removed", job_id, exc_info=True)


def discard_superseded(files: BlobStore, job_id: uuid.UUID, attempt: int, stored: Iterable[StoredArtifact],
                       but: int | None = None) -> None:
    """The job has ended with attempt ``attempt`` (its result committed, or its failure): the outputs its earlier
    attempts kept go too, but for ``but`` (the one the caller discards itself) and the payloads an artifact now
    stores. Such an output was superseded, not adopted: solved by another solver version, unreadable, or kept by an
    attempt that lost its lease and went on solving after the next attempt had looked for it. No attempt runs after
    an end, so none would adopt it; left, it would lie in the blob store for good. An attempt that kept nothing costs
    one ``exists`` (none on a first attempt). Best effort, as :func:`discard`: the job's end is written already, and
    a blob store that fails here leaves an orphan, never a failed job."""
    stored = list(stored)
    try:
        for earlier in range(1, attempt + 1):
            if earlier == but or not kept_by(files, job_id, earlier):
                continue
            try:
                payloads = json.loads(files.get(result_key(job_id, earlier))).get("payloads", [])
            except BlobStoreUnavailable:
                continue  # its index is what finds its payloads: kept for a later end to remove
            except (BlobMissing, ValueError, AttributeError):
                payloads = []  # unreadable: its result goes, the payloads it named cannot be found
            discard(files, job_id, earlier, payloads, stored)
    except Exception:
        log.warning("the outputs earlier attempts of job %s kept could not be removed", job_id, exc_info=True)


def described(computed: Computed) -> dict[str, Any] | None:
    """What :func:`discard` needs of the output kept in the blob store (None: nothing was kept); a result spooled for
    a later attempt carries it."""
    if not computed.kept and not computed.payloads:
        return None
    return {"attempt": computed.attempt, "payloads": sorted(computed.payloads)}
