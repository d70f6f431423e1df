"""Every ended attempt's history entry says when the attempt started (its claim), whoever ended it: the runner, a
cancel, the lease policy (a dead process, a lapsed lease, a gone worker), the kill at the hard time limit, a
hand-back. On main only the runner's own entries had a start. And an output an attempt kept that no attempt adopted
(superseded: another solver version, unreadable, a lost attempt's kept after the next had looked) goes from the blob
store when the job ends, as an adopted one does."""

from __future__ import annotations

import dataclasses
import json
import time
import uuid
from datetime import datetime, timedelta

import pytest

from plantsolve.jobs import computed
from plantsolve.jobs.computed import payload_key, result_key
from plantsolve.jobs.leases import process_died, sweep_once
from plantsolve.jobs.runner import fail_killed_at_hard_limit, handed_back, run_job
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import Solved
from plantsolve.store.models import utcnow
from tests.support.dispatch import Recorder
from tests.support.running import running_in_thread


def _submit(ctx, body: str) -> uuid.UUID:
    return JobService(ctx, Recorder()).submit_json("test-compute", body.encode(), None).job.id


def _claimed(ctx, job_id, worker: str, lease_seconds: float = 60) -> tuple[datetime, datetime]:
    """The attempt claimed by ``worker``, and the times just before and after its claim."""
    before = utcnow()
    assert ctx.repo.claim(job_id, lease_seconds=lease_seconds, worker=worker) is not None
    return before, utcnow()


def _entry(ctx, job_id, attempt: int) -> dict:
    return next(h for h in ctx.repo.get(job_id).attempts if h["attempt"] == attempt)


def _started_within(entry: dict, window: tuple[datetime, datetime]) -> None:
    started = datetime.fromisoformat(entry["started_at"].replace("Z", "+00:00"))
    assert window[0] - timedelta(milliseconds=1) <= started <= window[1] + timedelta(milliseconds=1), entry
    assert started <= datetime.fromisoformat(entry["finished_at"].replace("Z", "+00:00"))


def test_a_cancelled_attempt_starts_at_its_claim(ctx):
    job_id = _submit(ctx, '{"values": [1], "seconds": 20}')
    before = utcnow()
    thread, outcome = running_in_thread(ctx, job_id)
    window = (before, utcnow())
    JobService(ctx, Recorder()).cancel(job_id)
    thread.join(timeout=10)
    (entry,) = ctx.repo.get(job_id).attempts
    assert entry["outcome"] == "cancelled" and outcome == ["cancelled"]
    _started_within(entry, window)  # main: no started_at


@pytest.mark.parametrize("end", ["process_died", "lapsed", "gone", "hard_limit", "handed_back"])
def test_an_attempt_the_service_ends_starts_at_its_claim(ctx, end):
    job_id = _submit(ctx, '{"values": [1]}')
    window = _claimed(ctx, job_id, "w1", lease_seconds=0.01 if end == "lapsed" else 60)
    time.sleep(0.03)  # the end is later than the start (and the short lease lapsed): a start taken at the end is seen
    if end == "process_died":
        assert process_died(ctx, job_id, "w1", -9) == "requeued"
    elif end == "lapsed":
        sweep_once(ctx, Recorder().enqueue)
    elif end == "gone":
        sweep_once(ctx, Recorder().enqueue, gone=lambda worker: worker == "w1")
    elif end == "hard_limit":
        assert fail_killed_at_hard_limit(ctx, job_id, worker="w1")
    else:
        assert handed_back(ctx, job_id)
    entry = _entry(ctx, job_id, 1)
    assert entry["outcome"] == {"hard_limit": "time_limit", "handed_back": "handed_back"}.get(end, "lost"), entry
    _started_within(entry, window)


def test_each_attempt_starts_at_its_own_claim(ctx):
    job_id = _submit(ctx, '{"values": [3, 4]}')
    first = _claimed(ctx, job_id, "w1")
    time.sleep(0.02)
    assert process_died(ctx, job_id, "w1", -9) == "requeued"
    before = utcnow()
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    second = (before, utcnow())
    _started_within(_entry(ctx, job_id, 1), first)
    _started_within(_entry(ctx, job_id, 2), second)
    assert _entry(ctx, job_id, 1)["finished_at"] <= _entry(ctx, job_id, 2)["started_at"]


def test_the_claim_records_the_attempts_start_and_the_first_start_stays(ctx):
    job_id = _submit(ctx, '{"values": [1]}')
    _claimed(ctx, job_id, "w1")
    first = ctx.repo.get(job_id)
    assert first.attempt_started_at is not None and first.attempt_started_at == first.started_at
    time.sleep(0.01)
    process_died(ctx, job_id, "w1", -9)
    _claimed(ctx, job_id, "w2")
    second = ctx.repo.get(job_id)
    assert second.started_at == first.started_at and second.attempt_started_at > first.attempt_started_at


# ---- outputs kept by attempts that no attempt adopted -------------------------------------------------------------

def _blobs(ctx, job_id) -> list[str]:
    return sorted(str(p.relative_to(ctx.files.root)) for p in (ctx.files.root / str(job_id)).rglob("*") if p.is_file())


def _kept_by_attempt_1(ctx, job_id, version: str = "test-1", payloads: dict | None = None) -> None:
    """What attempt 1 leaves when its process is killed after keeping its output: the kept blobs, the attempt lost."""
    spec = dataclasses.replace(ctx.spec("test-compute"), version=version)
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
    solved = Solved(spec.solve(spec.request_model.model_validate({"values": [1.0]}), lambda *a: None).result,
                    payloads or {})
    result_json = solved.result.model_dump(mode="json")
    assert computed.keep(ctx.files, spec, job_id, 1, solved, result_json, json.dumps(result_json), 0.1).kept
    assert process_died(ctx, job_id, "w1", -9) == "requeued"


def test_a_kept_output_of_another_solver_version_goes_when_the_next_attempt_commits(ctx):
    job_id = _submit(ctx, '{"values": [2]}')
    _kept_by_attempt_1(ctx, job_id, version="test-0", payloads={"table.npy": b"scratch"})
    assert ctx.files.exists(result_key(job_id, 1)) and ctx.files.exists(payload_key(job_id, 1, "table.npy"))
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    # main: a1/.computed.json and a1/.computed-table.npy stayed for good
    assert _blobs(ctx, job_id) == [f"{job_id}/a2/summary.json", f"{job_id}/a2/values.txt"]


def test_an_unreadable_kept_output_goes_when_the_next_attempt_commits(ctx):
    job_id = _submit(ctx, '{"values": [2]}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
    ctx.files.put(result_key(job_id, 1), b'{"attempt": 1, "solver_version": "test-1", "resu')  # cut by the kill
    assert process_died(ctx, job_id, "w1", -9) == "requeued"
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert _blobs(ctx, job_id) == [f"{job_id}/a2/summary.json", f"{job_id}/a2/values.txt"]


def test_a_lost_attempts_output_kept_after_the_next_attempt_looked_goes_at_that_ones_commit(ctx, monkeypatch):
    """Attempt 1 lost its lease but solved on; it kept its output just after attempt 2 looked for one (and found
    none, so solved too). Attempt 2's commit holds the result: attempt 1's output is no one's."""
    job_id = _submit(ctx, '{"values": [2]}')
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
    assert process_died(ctx, job_id, "w1", -9) == "requeued"
    real_adopt = computed.adopt
    spec = ctx.spec("test-compute")

    def adopt_then_attempt_1_keeps(files, spec_, job, attempt):
        found = real_adopt(files, spec_, job, attempt)
        solved = spec.solve(spec.request_model.model_validate({"values": [2.0]}), lambda *a: None)
        computed.keep(files, spec, job_id, 1, solved, solved.result.model_dump(mode="json"), "{}", 0.1)
        return found

    monkeypatch.setattr(computed, "adopt", adopt_then_attempt_1_keeps)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert ctx.repo.get(job_id).result["total"] == 2.0
    assert _blobs(ctx, job_id) == [f"{job_id}/a2/summary.json", f"{job_id}/a2/values.txt"]


def test_a_kept_output_goes_when_the_job_fails_on_a_later_attempt(ctx, monkeypatch):
    job_id = _submit(ctx, '{"values": [2]}')
    _kept_by_attempt_1(ctx, job_id, version="test-0")
    spec = dataclasses.replace(ctx.spec("test-compute"), solve=lambda request, progress: 1 / 0)
    monkeypatch.setattr(ctx, "spec", lambda kind: spec)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "failed"
    assert _blobs(ctx, job_id) == []


def test_an_adopted_output_still_goes_and_its_artifacts_stay(ctx):
    job_id = _submit(ctx, '{"values": [2]}')
    _kept_by_attempt_1(ctx, job_id)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert _entry(ctx, job_id, 2)["error"] == "result computed by attempt 1"
    assert _blobs(ctx, job_id) == [f"{job_id}/a1/summary.json", f"{job_id}/a1/values.txt"]
