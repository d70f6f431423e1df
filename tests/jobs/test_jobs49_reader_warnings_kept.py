"""The reader's warnings reach every report a job ends with: a job whose process is lost (killed mid-solve, or its
lease lapsed) and one killed at its hard time limit keep them, as a job whose solve raises does; and a kind whose
request keeps only its source's text (alignment's PCF) has its reader's warnings in a failed job's report too, by the
same mechanism as every kind (its spec names the function that says them again)."""

from __future__ import annotations

import dataclasses
import threading
import time
import uuid
from datetime import timedelta

import pytest
from sqlalchemy import update

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.leases import process_died, sweep_once
from plantsolve.jobs.reader_notes import reader_warnings
from plantsolve.jobs.runner import fail_killed_at_hard_limit, run_job
from plantsolve.solvers.base import SolverError, StoredInput
from plantsolve.store.models import utcnow
from plantsolve.store.repository import JOBS
from tests.conftest import REPO, service_settings
from tests.support.dispatch import Recorder, stored_upload
from tests.support.pcf_lines import elbow_line

SCAN = (REPO / "examples" / "tube" / "scan.xyz").read_bytes() + b"12.0 abc 4\n"  # line 4001 is skipped


def _context(tmp_path, **settings) -> ServiceContext:
    return ServiceContext.create(service_settings(tmp_path, **settings), migrate=True)


def _codes(report: dict | None) -> list[str]:
    return [w["code"] for w in (report or {}).get("warnings") or []]


class _Hanging:
    """A solve that waits (a process killed or stopped mid-solve, as its job's row sees it) until released."""

    def __init__(self):
        self.entered, self.release = threading.Event(), threading.Event()

    def __call__(self, job_input, progress):
        self.entered.set()
        self.release.wait(30)
        raise SolverError("fit", "released")


def _running(ctx: ServiceContext, job_id: uuid.UUID) -> tuple[threading.Thread, _Hanging]:
    """The job's attempt under way in a thread, its input read, its solve waiting."""
    hanging = _Hanging()
    ctx.kinds = {**ctx.kinds, "tube": dataclasses.replace(ctx.spec("tube"), solve=hanging, render_artifacts=None)}
    thread = threading.Thread(target=run_job, args=(ctx, job_id), kwargs={"worker": "w", "requeue": Recorder().enqueue})
    thread.start()
    assert hanging.entered.wait(30)
    return thread, hanging


@pytest.mark.parametrize("attempts", [1, 3], ids=["last-attempt-failed", "re-queued"])
def test_a_job_whose_process_died_keeps_the_readers_warnings(tmp_path, attempts):
    ctx = _context(tmp_path, max_attempts=attempts)
    try:
        job_id = stored_upload(ctx, "tube", "scan.xyz", SCAN)
        thread, hanging = _running(ctx, job_id)
        # the running job already says how its file was read
        assert _codes(ctx.repo.get(job_id).report) == ["records_skipped"]
        assert process_died(ctx, job_id, "w", -9) == ("failed" if attempts == 1 else "requeued")
        hanging.release.set()
        thread.join(30)
        job = ctx.repo.get(job_id)
        assert job.status == ("failed" if attempts == 1 else "queued")
        assert job.report["stage"] == "worker" and "signal 9" in job.report["message"]
        assert _codes(job.report) == ["records_skipped"] and "line 4001" in job.report["warnings"][0]["message"]
    finally:
        ctx.close()


def test_a_job_whose_lease_lapsed_keeps_the_readers_warnings(tmp_path):
    # a stopped process beats no more: a beat of the running thread between the lapse and the sweep would renew the
    # lease, and the sweep would rightly leave the attempt alone (on a loaded machine it did, now and then)
    ctx = _context(tmp_path, max_attempts=1, heartbeat_seconds=60)
    try:
        job_id = stored_upload(ctx, "tube", "scan.xyz", SCAN)
        thread, hanging = _running(ctx, job_id)
        with ctx.db.engine.begin() as connection:  # the process stopped: no heartbeat renewed its lease
            connection.execute(update(JOBS).where(JOBS.c.id == job_id)
                               .values(lease_until=utcnow() - timedelta(seconds=60)))
        sweep_once(ctx, Recorder().enqueue)
        hanging.release.set()
        thread.join(30)
        job = ctx.repo.get(job_id)
        assert job.status == "failed" and "no heartbeat" in job.report["message"]
        assert _codes(job.report) == ["records_skipped"]
    finally:
        ctx.close()


def test_a_job_killed_at_its_hard_time_limit_keeps_the_readers_warnings(tmp_path):
    ctx = _context(tmp_path)
    try:
        job_id = stored_upload(ctx, "tube", "scan.xyz", SCAN)
        thread, hanging = _running(ctx, job_id)
        assert fail_killed_at_hard_limit(ctx, job_id, worker="w")
        hanging.release.set()
        thread.join(30)
        job = ctx.repo.get(job_id)
        assert (job.status, job.report["stage"]) == ("failed", "time_limit")
        assert _codes(job.report) == ["records_skipped"]
    finally:
        ctx.close()


CONTRADICTED = elbow_line(45.0, "9000")  # ANGLE 9000 (90 deg) on line 12 of an elbow its points make 45 deg


def test_a_failed_alignment_of_a_pcf_keeps_its_readers_warnings(tmp_path):
    ctx = _context(tmp_path)
    try:
        job_id = stored_upload(ctx, "alignment", "line.pcf", CONTRADICTED.encode())

        def fails(job_input, progress):
            raise SolverError("kkt", "the constraint system is singular")

        ctx.kinds = {**ctx.kinds, "alignment": dataclasses.replace(ctx.spec("alignment"), solve=fails,
                                                                   render_artifacts=None)}
        assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
        report = ctx.repo.get(job_id).report
        assert (report["stage"], report["message"]) == ("kkt", "the constraint system is singular")
        (kept,) = [w for w in report["warnings"] if w["code"] == "pcf_records_contradict_points"]
        assert "line 12: ANGLE 9000" in kept["message"]
    finally:
        ctx.close()


def test_alignment_reader_warnings_are_those_a_succeeded_job_reports(tmp_path):
    """The words said again for a failed job are the ones the solve puts in a succeeded job's report; notes that are
    details there (``pcf_items``) are no warning here either."""
    spec = _context(tmp_path).spec("alignment")
    request = spec.parse_upload(StoredInput.from_bytes("line.pcf", CONTRADICTED.encode()), {})
    said = reader_warnings(request, spec)
    solved = spec.solve(request, lambda fraction, message="": None).result.report.warnings
    by_code = {w.code: w.model_dump(mode="json") for w in solved}
    assert said and all(by_code[w["code"]] == w for w in said)
    assert "pcf_items" not in {w["code"] for w in said}
    # a JSON request without the PCF's text has none to say
    assert reader_warnings(request.model_copy(update={"source_pcf": None}), spec) == []


def test_a_job_read_without_warnings_writes_no_report_while_it_runs(tmp_path):
    ctx = _context(tmp_path)
    try:
        job_id = stored_upload(ctx, "tube", "scan.xyz", (REPO / "examples" / "tube" / "scan.xyz").read_bytes())
        thread, hanging = _running(ctx, job_id)
        time.sleep(0.2)
        assert ctx.repo.get(job_id).report is None
        hanging.release.set()
        thread.join(30)
    finally:
        ctx.close()
