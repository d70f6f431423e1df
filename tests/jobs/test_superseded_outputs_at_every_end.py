"""An output an attempt kept that no attempt adopted goes however the job ends: also a cancel, the lease policy's
failure at the attempts' cap and the kill at the hard time limit (they ended the job and left it in the blob store
for good); and removing it is best effort, as the adopted output's removal is: a blob store that fails then leaves an
orphan, never an error where the job's end is already written, and one that cannot be read keeps the index that
finds the output's payloads."""

from __future__ import annotations

import dataclasses
import json
import logging
import uuid


from plantsolve.jobs import computed
from plantsolve.jobs.computed import payload_key, result_key
from plantsolve.jobs.leases import process_died
from plantsolve.jobs.runner import fail_killed_at_hard_limit
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import Solved
from plantsolve.store.blobs import BlobStoreUnavailable
from tests.support.dispatch import Recorder


def _blobs(ctx, job_id) -> list[str]:
    return sorted(str(p.relative_to(ctx.files.root)) for p in (ctx.files.root / str(job_id)).rglob("*") if p.is_file())


def _job_whose_attempt_1_kept_an_output_of_another_version(ctx) -> uuid.UUID:
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [2]}', None).job.id
    spec = dataclasses.replace(ctx.spec("test-compute"), version="test-0")
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
    solved = Solved(spec.solve(spec.request_model.model_validate({"values": [1.0]}), lambda *a: None).result,
                    {"table.npy": b"scratch"})
    result_json = solved.result.model_dump(mode="json")
    assert computed.keep(ctx.files, spec, job_id, 1, solved, result_json, json.dumps(result_json), 0.1).kept
    assert process_died(ctx, job_id, "w1", -9) == "requeued"
    assert _blobs(ctx, job_id) == [f"{job_id}/a1/.computed-table.npy", f"{job_id}/a1/.computed.json"]
    return job_id


def test_a_cancel_removes_an_output_no_attempt_adopted(ctx):
    job_id = _job_whose_attempt_1_kept_an_output_of_another_version(ctx)
    assert JobService(ctx, Recorder()).cancel(job_id).status == "cancelled"
    assert _blobs(ctx, job_id) == []


def test_the_kill_at_the_hard_time_limit_removes_an_output_no_attempt_adopted(ctx):
    job_id = _job_whose_attempt_1_kept_an_output_of_another_version(ctx)
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w2") == 2
    assert fail_killed_at_hard_limit(ctx, job_id, worker="w2")
    assert ctx.repo.get(job_id).status == "failed"
    assert _blobs(ctx, job_id) == []


def test_the_lease_policys_failure_at_the_cap_removes_an_output_no_attempt_adopted(ctx):
    job_id = _job_whose_attempt_1_kept_an_output_of_another_version(ctx)
    outcome, attempt = "requeued", 1
    while outcome == "requeued":  # every later attempt's process dies before it keeps anything
        attempt += 1
        assert ctx.repo.claim(job_id, lease_seconds=60, worker=f"w{attempt}") == attempt
        outcome = process_died(ctx, job_id, f"w{attempt}", -9)
    assert outcome == "failed" and ctx.repo.get(job_id).status == "failed"
    assert _blobs(ctx, job_id) == []


class _Failing:
    """The job's blob store, failing in ``get`` as told."""

    def __init__(self, files, error: Exception):
        self._files, self._error = files, error

    def __getattr__(self, name):
        return getattr(self._files, name)

    def get(self, key):
        raise self._error


def test_a_blob_store_that_fails_leaves_the_output_and_raises_nothing(ctx, caplog):
    job_id = _job_whose_attempt_1_kept_an_output_of_another_version(ctx)
    with caplog.at_level(logging.WARNING):
        computed.discard_superseded(_Failing(ctx.files, RuntimeError("driver error")), job_id, 2, [])
    assert "could not be removed" in caplog.text
    assert _blobs(ctx, job_id) == [f"{job_id}/a1/.computed-table.npy", f"{job_id}/a1/.computed.json"]


def test_an_unreachable_index_is_kept_so_a_later_end_finds_its_payloads(ctx):
    job_id = _job_whose_attempt_1_kept_an_output_of_another_version(ctx)
    computed.discard_superseded(_Failing(ctx.files, BlobStoreUnavailable("away")), job_id, 2, [])
    assert ctx.files.exists(result_key(job_id, 1)) and ctx.files.exists(payload_key(job_id, 1, "table.npy"))
    computed.discard_superseded(ctx.files, job_id, 2, [])  # reachable again: both go
    assert _blobs(ctx, job_id) == []
