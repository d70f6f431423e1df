"""Nothing is solved twice: a job process killed after its solve and before its result's commit leaves the solve's
output in the blob store (keyed by the job and the attempt), and the next attempt adopts it instead of solving again.
A kill is a BaseException raised at the step named (the runner catches Exception only, as a killed process runs
nothing more), and the lease policy then loses the attempt as it does for a dead job process."""

from __future__ import annotations

import dataclasses
import uuid

import pytest

from plantsolve.jobs.computed import payload_key, result_key
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import process_died
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import Artifact, Solved
from tests.conftest import service_settings
from tests.support.dispatch import Recorder


class Killed(BaseException):
    """The job process's end: nothing after it runs."""


@pytest.fixture
def ctx(tmp_path, request):
    context = ServiceContext.create(service_settings(tmp_path, blob_store=getattr(request, "param", "local")),
                                    migrate=True)
    yield context
    context.close()


def _submit(ctx, body: str) -> uuid.UUID:
    return JobService(ctx, Recorder()).submit_json("test-compute", body.encode(), None).job.id


def _solves(markers) -> int:
    return len(list(markers.iterdir())) if markers.exists() else 0


def _killed_once(monkeypatch, owner, name: str) -> None:
    """``owner.name`` kills the process the first time it is called, and works after."""
    real = getattr(owner, name)
    calls = []

    def kill_first(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise Killed(name)
        return real(*args, **kwargs)

    monkeypatch.setattr(owner, name, kill_first)


def _patch_spec(ctx, monkeypatch, **changes) -> None:
    spec = dataclasses.replace(ctx.spec("test-compute"), **changes)
    real = ctx.spec
    monkeypatch.setattr(ctx, "spec", lambda kind: spec if kind == "test-compute" else real(kind))


def _run_killed(ctx, job_id, worker="w1") -> None:
    with pytest.raises(Killed):
        run_job(ctx, job_id, worker=worker, requeue=Recorder().enqueue)
    assert process_died(ctx, job_id, worker, -9) == "requeued"


def _blobs(ctx, job_id) -> list[str]:
    return sorted(str(p.relative_to(ctx.files.root)) for p in (ctx.files.root / str(job_id)).rglob("*") if p.is_file())


@pytest.mark.parametrize("step, ctx", [("render", "local"), ("commit", "local"), ("commit", "postgres")],
                         indirect=["ctx"])
def test_a_process_killed_between_its_solve_and_the_commit_is_not_solved_again(ctx, tmp_path, monkeypatch, step):
    """On the blob back-ends of both paths: a local folder (embedded), the database's table (scaled; here on
    SQLite)."""
    markers = tmp_path / "runs"
    job_id = _submit(ctx, f'{{"values": [3, 4], "marker_dir": "{markers}"}}')
    if step == "render":
        spec = ctx.spec("test-compute")
        calls = []

        def render(request, solved):
            calls.append(1)
            if len(calls) == 1:
                raise Killed("render")
            return spec.render_artifacts(request, solved)

        _patch_spec(ctx, monkeypatch, render_artifacts=render)
    else:
        _killed_once(monkeypatch, ctx.repo, "finish_success")
    _run_killed(ctx, job_id)
    assert _solves(markers) == 1
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    job = ctx.repo.get(job_id)
    assert _solves(markers) == 1  # main: 2, the second attempt solved again
    assert job.result["norm"] == 5.0 and job.result["report"]["status"] == "ok"
    assert [(h["attempt"], h["worker"], h["outcome"]) for h in job.attempts] == [(1, "w1", "lost"), (2, "w2", "succeeded")]
    assert job.attempts[1]["error"] == "result computed by attempt 1"
    assert JobService(ctx, Recorder()).artifact(job_id, "values.txt")[1].read() == b"3.0\n4.0"
    # the kept result went with the commit; the artifacts stay under the attempt that computed them
    assert sorted(a.path for a in ctx.repo.artifacts(job_id)) == [f"{job_id}/a1/summary.json", f"{job_id}/a1/values.txt"]
    assert not ctx.files.exists(result_key(job_id, 1))


def test_a_job_that_is_not_killed_leaves_only_its_artifacts(ctx, monkeypatch):
    job_id = _submit(ctx, '{"values": [1, 2]}')
    kept = []
    real_put = ctx.files.put
    monkeypatch.setattr(ctx.files, "put", lambda key, data: kept.append(key) or real_put(key, data))
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    assert kept[0] == result_key(job_id, 1)  # kept before the artifacts are even rendered
    assert _blobs(ctx, job_id) == [f"{job_id}/a1/summary.json", f"{job_id}/a1/values.txt"]
    assert [h["outcome"] for h in ctx.repo.get(job_id).attempts] == ["succeeded"]


def test_the_kept_result_of_the_last_attempt_gets_an_attempt_to_be_stored(tmp_path, monkeypatch):
    context = ServiceContext.create(service_settings(tmp_path, max_attempts=1), migrate=True)
    try:
        markers = tmp_path / "runs"
        job_id = _submit(context, f'{{"values": [6, 8], "marker_dir": "{markers}"}}')
        _killed_once(monkeypatch, context.repo, "finish_success")
        _run_killed(context, job_id)  # main: "failed", lost on its only attempt with its result computed
        job = context.repo.get(job_id)
        assert job.status == "queued" and job.max_attempts == 2
        assert "result was kept" in job.attempts[0]["error"]
        assert run_job(context, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
        assert context.repo.get(job_id).result["norm"] == 10.0 and _solves(markers) == 1
    finally:
        context.close()


def test_a_payload_an_artifact_stores_is_written_once_and_adopted_with_the_result(ctx, tmp_path, monkeypatch):
    """A kind whose artifact is a payload of its solve (dedup's optimized model): the payload's blob is the artifact's,
    and an attempt that adopts the result renders the artifact from the kept payload."""
    spec = ctx.spec("test-compute")
    model = bytes(range(256)) * 64

    def solve(request, progress):
        return Solved(spec.solve(request, progress).result, {"model.bin": model, "table.npy": b"scratch"})

    def render(request, solved):
        return [*spec.render_artifacts(request, solved),
                Artifact("model.bin", "application/octet-stream", solved.files["model.bin"])]

    _patch_spec(ctx, monkeypatch, solve=solve, render_artifacts=render)
    written = []
    real_put = ctx.files.put
    monkeypatch.setattr(ctx.files, "put", lambda key, data: written.append(key) or real_put(key, data))
    _killed_once(monkeypatch, ctx.repo, "finish_success")
    job_id = _submit(ctx, '{"values": [1]}')
    _run_killed(ctx, job_id)
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert written.count(payload_key(job_id, 1, "model.bin")) == 1 and not any(k.endswith("/model.bin") for k in written)
    assert JobService(ctx, Recorder()).artifact(job_id, "model.bin")[1].read() == model
    assert _blobs(ctx, job_id) == sorted([f"{job_id}/a1/summary.json", f"{job_id}/a1/values.txt",
                                          payload_key(job_id, 1, "model.bin")])


def test_a_result_kept_by_another_solver_version_is_solved_again(ctx, tmp_path, monkeypatch):
    markers = tmp_path / "runs"
    job_id = _submit(ctx, f'{{"values": [2], "marker_dir": "{markers}"}}')
    _killed_once(monkeypatch, ctx.repo, "finish_success")
    _run_killed(ctx, job_id)
    _patch_spec(ctx, monkeypatch, version="test-2")  # the workers were upgraded meanwhile
    assert run_job(ctx, job_id, worker="w2", requeue=Recorder().enqueue) == "succeeded"
    assert _solves(markers) == 2 and ctx.repo.get(job_id).attempts[1].get("error") is None


def test_a_blob_store_that_does_not_take_the_kept_result_costs_the_job_nothing(ctx, tmp_path, monkeypatch):
    real_put = ctx.files.put

    def put(key, data):
        if key.endswith(".computed.json"):
            raise OSError(28, "No space left on device")
        return real_put(key, data)

    monkeypatch.setattr(ctx.files, "put", put)
    job_id = _submit(ctx, '{"values": [5]}')
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "succeeded"
    assert ctx.repo.get(job_id).result["total"] == 5.0


def test_a_job_cancelled_while_its_artifacts_render_leaves_no_kept_result(ctx, monkeypatch):
    spec = ctx.spec("test-compute")
    job_id = _submit(ctx, '{"values": [7]}')

    def render(request, solved):
        JobService(ctx, Recorder()).cancel(job_id)
        return spec.render_artifacts(request, solved)

    _patch_spec(ctx, monkeypatch, render_artifacts=render)
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "stale"
    assert ctx.repo.get(job_id).status == "cancelled"
    assert not ctx.files.exists(result_key(job_id, 1))
