"""The runner gives the retry policy the kind's request model, so a stored input that no longer validates fails the
job with its fields named as the user wrote them (``points.2``), not with pydantic's union tags (``points.list.2``)."""

from __future__ import annotations

import json
from pathlib import Path


from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from tests.support.dispatch import Recorder

SCAN = (Path(__file__).resolve().parents[2] / "examples" / "tube" / "scan_request.json").read_bytes()


def test_a_stored_input_that_no_longer_validates_names_the_users_path(ctx):
    job = JobService(ctx, Recorder()).submit_upload("tube", "scan.json", SCAN, None, None).job
    stored = ctx.repo.get(job.id)
    assert stored.input_kind == "upload"
    body = json.loads(SCAN)
    body["points"][2] = [1.0, 2.0]  # as a schema that changed under the queued job would refuse it
    ctx.files.put(stored.input_file, json.dumps(body).encode())
    assert run_job(ctx, job.id, worker="w1", requeue=Recorder().enqueue) == "failed"
    errors = ctx.repo.get(job.id).report["details"]["errors"]
    assert [e["loc"] for e in errors] == [["file", "points", 2]], errors
