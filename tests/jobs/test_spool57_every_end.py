"""A result spooled for the next attempt (its commit failed for RESULT_WRITE_SECONDS) goes however its job ends: a
cancel, the runner's failure, the lease policy's failure at the cap, the kill at the hard time limit, another
attempt's result, or a spool written after the end (an attempt that lost the job while it waited for the database).
An attempt that was to store a spooled result and could not is granted no further attempt (the job ends at its
cap). A process killed between its commit and its clean-up leaves it to the next look at the job (its death, a delivery
again) or to the start-up sweep, which also removes a spool cut short (artifacts without their result).

Each test counts every file of the blob folder: what a job that ended holds is its result's artifacts, nothing else."""

from __future__ import annotations

import uuid

import pytest
from sqlalchemy.exc import OperationalError

from plantsolve.jobs import spool
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import process_died
from plantsolve.jobs.runner import fail_killed_at_hard_limit, run_job
from plantsolve.jobs.service import JobService
from plantsolve.workers.sweeper import Sweeper
from tests.conftest import service_settings
from tests.support.dispatch import Recorder


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, result_write_seconds=0.2), migrate=True)
    yield context
    context.close()


def _away(*args, **kwargs):
    raise OperationalError("UPDATE jobs ...", {}, ConnectionError("server closed the connection"))


def _files(ctx) -> list[str]:
    root = ctx.files.root
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())


def _artifacts(ctx, job_id) -> list[str]:
    return sorted(a.path for a in ctx.repo.artifacts(job_id))


def _spooled(ctx, monkeypatch, tmp_path) -> uuid.UUID:
    """A job whose attempt 1 solved and spooled its result (the database refused its commit); queued again."""
    job_id = JobService(ctx, Recorder()).submit_json(
        "test-compute", f'{{"values": [3, 4], "marker_dir": "{tmp_path / "runs"}"}}'.encode(), None).job.id
    with monkeypatch.context() as patch:
        patch.setattr(ctx.repo, "finish_success", _away)
        assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "requeued"
    assert spool.holder(ctx, job_id) is ctx.files
    assert f"{job_id}/a1/values.txt" in _files(ctx)  # stored before the commit failed: the spool names it
    return job_id


def test_a_cancel_removes_the_spool_and_the_artifacts_it_had_stored(ctx, monkeypatch, tmp_path):
    job_id = _spooled(ctx, monkeypatch, tmp_path)
    assert JobService(ctx, Recorder()).cancel(job_id).status == "cancelled"
    assert _files(ctx) == []


def test_the_runners_failure_removes_the_spool(ctx, monkeypatch, tmp_path):
    job_id = _spooled(ctx, monkeypatch, tmp_path)

    def refused(*args, **kwargs):
        raise ValueError("a row the database refuses")  # no outage: the job fails at once

    monkeypatch.setattr(ctx.repo, "finish_success", refused)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "failed"
    assert _files(ctx) == []


def test_the_lease_policys_failure_at_the_cap_removes_the_spool(ctx, monkeypatch, tmp_path):
    job_id = _spooled(ctx, monkeypatch, tmp_path)
    outcomes = []
    for attempt in range(2, 8):  # each later attempt's process dies before it stores the spooled result
        assert ctx.repo.claim(job_id, lease_seconds=60, worker=f"w{attempt}") == attempt
        outcomes.append(process_died(ctx, job_id, f"w{attempt}", -9))
        if outcomes[-1] != "requeued":
            break
    # the cap (3) holds: the grant is for the attempt that spooled, not for each one that failed to store it
    assert outcomes == ["requeued", "failed"] and ctx.repo.get(job_id).status == "failed"
    assert _files(ctx) == []


def test_the_kill_at_the_hard_time_limit_removes_the_spool(ctx, monkeypatch, tmp_path):
    job_id = _spooled(ctx, monkeypatch, tmp_path)
    assert ctx.repo.claim(job_id, lease_seconds=60, worker="w2") == 2
    assert fail_killed_at_hard_limit(ctx, job_id, worker="w2")
    assert _files(ctx) == []


def test_storing_the_spooled_result_leaves_the_jobs_artifacts_alone(ctx, monkeypatch, tmp_path):
    job_id = _spooled(ctx, monkeypatch, tmp_path)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert f"{job_id}/a1/values.txt" in _artifacts(ctx, job_id)  # attempt 1's, stored before its commit failed
    assert _files(ctx) == _artifacts(ctx, job_id)
    assert len(list((tmp_path / "runs").iterdir())) == 1  # solved once


def test_a_spool_written_after_a_cancel_goes_at_once(ctx, monkeypatch, tmp_path):
    """The job was cancelled while its attempt waited for the database: the attempt spools, its re-queue is refused
    (fenced), and the spool goes (it lay in the blob store for good)."""
    job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [3, 4]}', None).job.id
    cancelled = []

    def away_and_cancelled(*args, **kwargs):
        if not cancelled:
            cancelled.append(JobService(ctx, Recorder()).cancel(job_id).status)
        _away()

    monkeypatch.setattr(ctx.repo, "finish_success", away_and_cancelled)
    assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "stale"
    assert cancelled == ["cancelled"] and ctx.repo.get(job_id).status == "cancelled"
    assert _files(ctx) == []


def test_a_spool_of_an_attempt_that_lost_its_lease_goes_once_another_attempt_stored_the_result(
        ctx, monkeypatch, tmp_path):
    """Attempt 1's commit waits for the database; meanwhile it is lost (its lease lapsed) and attempt 2 stores the
    result attempt 1 kept. Attempt 1 then spools, finds the job ended, and removes its spool: the job keeps exactly
    its artifacts."""
    job_id = JobService(ctx, Recorder()).submit_json(
        "test-compute", f'{{"values": [6, 8], "marker_dir": "{tmp_path / "runs"}"}}'.encode(), None).job.id
    commit = ctx.repo.finish_success
    second = []

    def first_waits(job, attempt, **kwargs):
        if attempt == 1:
            if not second:  # the sweep took attempt 1 back; attempt 2 runs elsewhere
                assert process_died(ctx, job_id, "w1", -9) == "requeued"
                second.append(run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue))
            _away()
        return commit(job, attempt, **kwargs)

    monkeypatch.setattr(ctx.repo, "finish_success", first_waits)
    assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "stale"
    job = ctx.repo.get(job_id)
    assert second == ["succeeded"] and job.status == "succeeded" and job.result["norm"] == 10.0
    assert spool.holder(ctx, job_id) is None
    assert _files(ctx) == _artifacts(ctx, job_id) != []


def _stored_by_a_process_killed_before_its_clean_up(ctx, monkeypatch, tmp_path) -> uuid.UUID:
    job_id = _spooled(ctx, monkeypatch, tmp_path)
    with monkeypatch.context() as patch:
        patch.setattr(spool, "remove", lambda *args, **kwargs: None)  # killed right after the commit
        assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert spool.holder(ctx, job_id) is not None
    return job_id


def test_the_death_of_the_process_that_committed_removes_what_it_left(ctx, monkeypatch, tmp_path):
    job_id = _stored_by_a_process_killed_before_its_clean_up(ctx, monkeypatch, tmp_path)
    assert process_died(ctx, job_id, "w2", -9) == "none"
    assert _files(ctx) == _artifacts(ctx, job_id) != []


def test_a_delivery_after_the_end_removes_what_the_killed_worker_left(ctx, monkeypatch, tmp_path):
    job_id = _stored_by_a_process_killed_before_its_clean_up(ctx, monkeypatch, tmp_path)
    assert run_job(ctx, job_id, worker="w3", requeue=Recorder().enqueue) == "skipped"
    assert _files(ctx) == _artifacts(ctx, job_id) != []


def test_the_start_up_sweep_removes_spools_of_ended_jobs_and_keeps_those_still_waiting(ctx, monkeypatch, tmp_path):
    ended = _stored_by_a_process_killed_before_its_clean_up(ctx, monkeypatch, tmp_path)
    waiting = _spooled(ctx, monkeypatch, tmp_path)
    cut_short = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
    assert ctx.repo.claim(cut_short, lease_seconds=60, worker="w1") == 1
    assert ctx.repo.finish_failure(cut_short, 1, report={"status": "failed"}, run_seconds=1.0)
    ctx.files.put(spool.pending_artifact_key(cut_short, "values.txt"), b"1.0")  # killed before its result's write
    ctx.files.put(f"{spool.PREFIX}{uuid.uuid4()}/result.json", b"{}")  # a job that is gone
    before = [f for f in _files(ctx) if waiting.hex[:8] in f]
    assert Sweeper(ctx, Recorder().enqueue).sweep_spool()
    assert spool.holder(ctx, waiting) is ctx.files  # its next attempt stores it
    assert [f for f in _files(ctx) if waiting.hex[:8] in f] == before
    assert [f for f in _files(ctx) if waiting.hex[:8] not in f] == _artifacts(ctx, ended)
    assert run_job(ctx, waiting, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert _files(ctx) == sorted([*_artifacts(ctx, ended), *_artifacts(ctx, waiting)])


def test_a_spool_cut_short_by_a_refusing_store_leaves_no_artifact(ctx, monkeypatch):
    job_id = uuid.uuid4()
    put = ctx.files.put

    def full_after_one(key, data):
        if key.endswith("result.json"):
            raise OSError(28, "No space left on device")
        return put(key, data)

    monkeypatch.setattr(ctx.files, "put", full_after_one)
    from plantsolve.solvers.base import Artifact

    with pytest.raises(OSError):
        spool.write(ctx, job_id, {"unstored": [{"name": "a.txt", "media_type": "text/plain"}]},
                    [Artifact("a.txt", "text/plain", b"x")])
    assert _files(ctx) == []


def test_a_result_the_database_never_takes_in_time_ends_the_job_at_its_cap(ctx, monkeypatch, tmp_path):
    """A write the database always refuses in time (a result too large for its statement timeout) re-queued the job
    for ever: every attempt at the cap that spooled the result again was granted one more."""
    job_id = JobService(ctx, Recorder()).submit_json(
        "test-compute", f'{{"values": [3, 4], "marker_dir": "{tmp_path / "runs"}"}}'.encode(), None).job.id
    monkeypatch.setattr(ctx.repo, "finish_success", _away)
    outcomes = []
    for attempt in range(1, 8):
        outcomes.append(run_job(ctx, job_id, worker=f"w{attempt}", requeue=Recorder().enqueue))
        if outcomes[-1] != "requeued":
            break
    job = ctx.repo.get(job_id)
    assert outcomes == ["requeued", "requeued", "failed"] and job.status == "failed"
    assert job.report["stage"] == "infrastructure" and "could not be stored in 3 attempts" in job.report["message"]
    assert [h["outcome"] for h in job.attempts] == ["result_pending", "result_pending", "failed"]
    assert len(list((tmp_path / "runs").iterdir())) == 1  # solved once
    assert _files(ctx) == []


def test_the_temporary_files_of_a_dead_process_go_and_another_processs_stay(ctx):
    from plantsolve.jobs.leases import remove_temporaries
    from plantsolve.store.blobs import temporary_prefix

    job_id = uuid.uuid4()
    dead, live = ctx.files.root / str(job_id) / "a1", ctx.files.root / spool.PREFIX / str(job_id) / "artifacts"
    for folder in (dead, live):
        folder.mkdir(parents=True)
    (dead / f"{temporary_prefix(4242)}x").write_bytes(b"half")
    (live / f"{temporary_prefix(4242)}y").write_bytes(b"half")
    (live / f"{temporary_prefix(4343)}z").write_bytes(b"under way")
    assert remove_temporaries(ctx, job_id, 4242) == 2
    assert _files(ctx) == [f"{spool.PREFIX}{job_id}/artifacts/{temporary_prefix(4343)}z"]
    assert not (ctx.files.root / str(job_id)).exists()  # its emptied folders went too


@pytest.mark.parametrize("damage", ["artifact missing", "result unreadable"])
def test_a_spooled_result_that_cannot_be_used_is_solved_again_not_a_failed_job(ctx, monkeypatch, tmp_path, damage):
    """It failed the job as the solver's failure on this input ("the same input fails the same way")."""
    job_id = JobService(ctx, Recorder()).submit_json(
        "test-compute", f'{{"values": [3, 4], "marker_dir": "{tmp_path / "runs"}"}}'.encode(), None).job.id
    with monkeypatch.context() as patch:  # the artifacts wait with the result: the blob store took none
        patch.setattr(ctx.repo, "finish_success", _away)
        put = ctx.files.put
        patch.setattr(ctx.files, "put", lambda key, data: put(key, data) if key.startswith(spool.PREFIX) or
                      ".computed" in key else _away())
        assert run_job(ctx, job_id, worker="w1", requeue=Recorder().enqueue) == "requeued"
    if damage == "artifact missing":
        ctx.files.delete(spool.pending_artifact_key(job_id, "values.txt"))
    else:
        ctx.files.put(spool.pending_path(job_id), b'{"attempt": 1, "artifacts": []')
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert job.result["norm"] == 5.0 and [h["outcome"] for h in job.attempts] == ["result_pending", "succeeded"]
    assert spool.holder(ctx, job_id) is None


def test_a_lapsed_attempt_that_finds_the_spool_half_removed_keeps_the_succeeded_jobs_artifacts(ctx, monkeypatch, tmp_path):
    import json

    job_id = _spooled(ctx, monkeypatch, tmp_path)
    # a spool with an artifact the blob store had refused: the storing attempt removes that blob before the index
    key = spool.pending_path(job_id)
    payload = json.loads(ctx.files.get(key))
    payload["unstored"] = [{"name": "plot.png", "media_type": "image/png"}]
    ctx.files.put(spool.pending_artifact_key(job_id, "plot.png"), b"png")
    ctx.files.put(key, json.dumps(payload).encode())
    real_delete = ctx.files.delete
    taken = []

    def delete(name):
        real_delete(name)
        if name == spool.pending_artifact_key(job_id, "plot.png") and not taken:
            taken.append("taking")
            taken.append(spool.take(ctx, job_id))  # an attempt whose lease lapsed reads the spool right now

    monkeypatch.setattr(ctx.files, "delete", delete)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert taken == ["taking", None]
    held = _artifacts(ctx, job_id)
    assert f"{job_id}/a1/values.txt" in held and all(ctx.files.exists(path) for path in held)


def test_a_spool_the_sweep_cannot_remove_does_not_keep_it_from_the_others(ctx, monkeypatch):
    ended = []
    for _ in range(2):
        job_id = JobService(ctx, Recorder()).submit_json("test-compute", b'{"values": [1]}', None).job.id
        assert ctx.repo.claim(job_id, lease_seconds=60, worker="w1") == 1
        assert ctx.repo.finish_failure(job_id, 1, report={"status": "failed"}, run_seconds=1.0)
        ctx.files.put(spool.pending_artifact_key(job_id, "values.txt"), b"1.0")
        ended.append(job_id)
    stuck = spool.pending_artifact_key(ended[0], "values.txt")
    real_delete = ctx.files.delete

    def delete(name):
        if name == stuck:
            raise PermissionError(name)  # not the store being away: a file this process may not remove
        real_delete(name)

    monkeypatch.setattr(ctx.files, "delete", delete)
    spool.sweep(ctx)
    assert _files(ctx) == [stuck]  # the other job's spool went
